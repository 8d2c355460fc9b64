"""aem_electrolyser.plot_validation turns the CSV of `aem-identify validate --csv` into a PNG."""

import subprocess
import sys

from conftest import ROOT

HEADER = (
    "time,setpoint,current_measured,current_model,voltage_measured,voltage_model,"
    "power_measured,power_model,h2_flow_measured,h2_flow_model,compared"
)


def test_plot_of_a_validation_trace(tmp_path):
    rows = [HEADER]
    for t in range(1200):
        i = 40.0 + (2.0 if t > 700 else 0.0)
        rows.append(
            f"{t},{75 if t <= 700 else 79},{i + 0.1},{i},{42.0},{41.9},{42 * (i + 0.1)},{41.9 * i},,{9.4 * i},{int(t >= 600)}"
        )
    trace = tmp_path / "validation.csv"
    trace.write_text("\n".join(rows) + "\n")
    png = tmp_path / "out" / "validation.png"
    result = subprocess.run(
        [sys.executable, "-m", "aem_electrolyser.plot_validation", str(trace), str(png)], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The trace header is the one the tool writes.
    rust = (ROOT / "crates" / "identify" / "src" / "validate.rs").read_text()
    assert f'"{HEADER}"' in rust
