//! Hydrogen production coefficient (paper §III-D): flow = c·I through the origin, by least
//! squares on the running samples: c = Σ F·I / Σ I², SE(c) = s/√(Σ I²) with
//! s² = Σ(F − c·I)²/(n − 1).
//!
//! Faraday's law for a stack of N cells gives the ideal coefficient
//!   c_ideal = N · 3600 s/h · V_m / (2F)   [Nl/(h·A)],
//! with F = 96 485.332 12 C/mol and V_m = 22.413 969 54 Nl/mol (0 °C, 101.325 kPa: the
//! normal litre of the model description's unit `Nl`), so the Faraday efficiency is c/c_ideal.

use super::columns::Channel;
use super::dynamics::Estimate;
use super::read::ModuleLog;

/// Faraday constant [C/mol].
pub const FARADAY: f64 = 96_485.332_12;
/// Molar volume of an ideal gas at 0 °C and 101.325 kPa [Nl/mol].
pub const MOLAR_VOLUME: f64 = 22.413_969_54;

/// Ideal hydrogen per ampere of a stack of `cells` cells [Nl/(h·A)].
pub fn ideal_coefficient(cells: u32) -> f64 {
    f64::from(cells) * 3600.0 * MOLAR_VOLUME / (2.0 * FARADAY)
}

/// The fitted hydrogen coefficient.
#[derive(Clone, Debug)]
pub struct HydrogenFit {
    /// c [Nl/(h·A)].
    pub coefficient: Estimate,
    /// RMSE of the flow [Nl/h].
    pub rmse: f64,
    /// Samples used.
    pub points: usize,
    /// Cells in the stack.
    pub cells: u32,
    /// c / c_ideal [-].
    pub faraday_efficiency: f64,
}

/// Fits flow = c·I over samples with current above `running_current` [A]; needs current and
/// hydrogen flow.
pub fn fit_hydrogen(
    log: &ModuleLog,
    running_current: f64,
    cells: u32,
) -> Result<HydrogenFit, String> {
    if !log.has(Channel::H2Flow) {
        return Err("no h2_flow column".into());
    }
    if cells == 0 {
        return Err("the cell count must be at least 1".into());
    }
    let (mut n, mut sii, mut sif, mut sff) = (0usize, 0.0, 0.0, 0.0);
    for block in &log.blocks {
        let (Some(current), Some(flow)) = (
            block.channel(Channel::Current),
            block.channel(Channel::H2Flow),
        ) else {
            continue;
        };
        for (i, f) in current.iter().zip(flow) {
            if *i > running_current {
                n += 1;
                sii += i * i;
                sif += i * f;
                sff += f * f;
            }
        }
    }
    if n < 2 {
        return Err(format!(
            "{n} running samples with hydrogen flow; at least 2 are needed"
        ));
    }
    let c = sif / sii;
    let rss = (sff - c * sif).max(0.0);
    let s = (rss / (n as f64 - 1.0)).sqrt();
    Ok(HydrogenFit {
        coefficient: Estimate {
            value: c,
            standard_error: s / sii.sqrt(),
        },
        rmse: (rss / n as f64).sqrt(),
        points: n,
        cells,
        faraday_efficiency: c / ideal_coefficient(cells),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_papers_coefficient_is_the_ideal_23_cell_stack() {
        // Table I: 9.6174 Nl/(h·A) for 23 cells.
        assert!(
            (ideal_coefficient(23) - 9.6174).abs() < 1e-3,
            "{}",
            ideal_coefficient(23)
        );
        // The model description's unit Nl is 0.044615033415450964 mol.
        assert!((1.0 / MOLAR_VOLUME - 0.044_615_033_415_450_964).abs() < 1e-12);
    }
}
