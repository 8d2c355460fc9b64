#!/usr/bin/env python3
"""Shrink a matplotlib PNG for docs/ by quantising it to a small palette (no dithering).

python scripts/shrink_png.py out/step_responses.png docs/images/step_responses.png [--colors 64]
"""

import argparse
from pathlib import Path

from PIL import Image
from aem_electrolyser.cli import quiet_on_closed_stdout, writable


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("src", type=Path)
    parser.add_argument("dst", type=Path)
    parser.add_argument("--colors", type=int, default=64, help="palette size")
    args = parser.parse_args(argv)
    writable(args.dst)
    image = Image.open(args.src).convert("RGB")
    image.quantize(colors=args.colors, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(
        args.dst, optimize=True
    )
    print(f"wrote {args.dst} ({args.dst.stat().st_size // 1024} kB)")


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
