//! Damping matrices: Rayleigh, from target damping ratios of two modes, or
//! modal damping ratios for every mode, plus optional discrete dashpots
//! (which make the damping non-proportional).

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{SimError, non_negative};
use crate::model::undamped_modes;

/// How the proportional part of the damping matrix is defined.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum DampingSpec {
    /// No proportional damping (dashpots only, or undamped).
    None,
    /// `damping = alpha M + beta K`; alpha in 1/s, beta in s.
    Rayleigh {
        /// Mass-proportional coefficient, 1/s.
        alpha: f64,
        /// Stiffness-proportional coefficient, s.
        beta: f64,
    },
    /// Rayleigh coefficients chosen so that two modes (1-based, in
    /// ascending frequency) have the given damping ratios.
    TargetRatios {
        /// The two modes, 1-based in ascending frequency.
        modes: [usize; 2],
        /// Their damping ratios.
        ratios: [f64; 2],
    },
    /// A damping ratio for every mode (ascending frequency):
    /// `damping = M Phi diag(2 xi_i w_i) Phi^T M` with mass-normalized Phi.
    Modal {
        /// One damping ratio per mode, ascending frequency.
        ratios: Vec<f64>,
    },
    /// The damping matrix given directly (rows), N s/m.
    Matrix {
        /// Rows of the damping matrix, N s/m.
        matrix: Vec<Vec<f64>>,
    },
}

/// A viscous dashpot across one storey (between floor `storey - 1`, the
/// ground for storey 1, and floor `storey`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dashpot {
    /// 1-based storey index.
    pub storey: usize,
    /// Viscous coefficient, N s/m.
    pub coefficient_ns_per_m: f64,
}

/// Rayleigh coefficients (alpha, beta) giving damping ratios `xi` at circular
/// frequencies `w`: `xi_i = alpha / (2 w_i) + beta w_i / 2`.
pub fn rayleigh_for_ratios(w: [f64; 2], xi: [f64; 2]) -> (f64, f64) {
    // 2x2 solve of [1/(2 w1), w1/2; 1/(2 w2), w2/2] [alpha; beta] = xi.
    let det = w[1] / (4.0 * w[0]) - w[0] / (4.0 * w[1]);
    let alpha = (xi[0] * w[1] / 2.0 - xi[1] * w[0] / 2.0) / det;
    let beta = (xi[1] / (2.0 * w[0]) - xi[0] / (2.0 * w[1])) / det;
    (alpha, beta)
}

/// Builds the damping matrix for mass `m` and stiffness `k`. Errors name
/// the field (`damping.…`, `dashpots[i].…`).
pub fn build_damping(
    m: &DMatrix<f64>,
    k: &DMatrix<f64>,
    spec: &DampingSpec,
    dashpots: &[Dashpot],
) -> Result<DMatrix<f64>, SimError> {
    let n = m.nrows();
    let mut r = match spec {
        DampingSpec::None => DMatrix::zeros(n, n),
        DampingSpec::Rayleigh { alpha, beta } => {
            non_negative("damping.alpha", *alpha)?;
            non_negative("damping.beta", *beta)?;
            m * *alpha + k * *beta
        }
        DampingSpec::TargetRatios { modes, ratios } => {
            for (i, &mode) in modes.iter().enumerate() {
                if mode == 0 || mode > n {
                    return Err(SimError::invalid(
                        format!("damping.modes[{i}]"),
                        format!("mode {mode} does not exist; modes are numbered 1..={n}"),
                    ));
                }
                non_negative(&format!("damping.ratios[{i}]"), ratios[i])?;
            }
            if modes[0] == modes[1] {
                return Err(SimError::invalid(
                    "damping.modes",
                    "the two modes must differ",
                ));
            }
            let (w2, _) = undamped_modes(m, k);
            let w = [w2[modes[0] - 1].sqrt(), w2[modes[1] - 1].sqrt()];
            let (alpha, beta) = rayleigh_for_ratios(w, *ratios);
            if alpha < 0.0 || beta < 0.0 {
                return Err(SimError::invalid(
                    "damping.ratios",
                    format!(
                        "no non-negative Rayleigh damping gives these ratios (alpha = {alpha:.4e}, beta = {beta:.4e})"
                    ),
                ));
            }
            m * alpha + k * beta
        }
        DampingSpec::Modal { ratios } => {
            if ratios.len() != n {
                return Err(SimError::invalid(
                    "damping.ratios",
                    format!("{} ratios given for {n} modes", ratios.len()),
                ));
            }
            for (i, &xi) in ratios.iter().enumerate() {
                non_negative(&format!("damping.ratios[{i}]"), xi)?;
            }
            let (w2, phi) = undamped_modes(m, k);
            let diag =
                nalgebra::DVector::from_iterator(n, (0..n).map(|i| 2.0 * ratios[i] * w2[i].sqrt()));
            let mphi = m * &phi;
            &mphi * DMatrix::from_diagonal(&diag) * mphi.transpose()
        }
        DampingSpec::Matrix { matrix } => matrix_from_rows("damping.matrix", matrix, n)?,
    };
    for (i, d) in dashpots.iter().enumerate() {
        if d.storey == 0 || d.storey > n {
            return Err(SimError::invalid(
                format!("dashpots[{i}].storey"),
                format!(
                    "storey {} does not exist; storeys are numbered 1..={n}",
                    d.storey
                ),
            ));
        }
        let c = non_negative(
            &format!("dashpots[{i}].coefficient_ns_per_m"),
            d.coefficient_ns_per_m,
        )?;
        let s = d.storey - 1;
        r[(s, s)] += c;
        if s > 0 {
            r[(s - 1, s - 1)] += c;
            r[(s - 1, s)] -= c;
            r[(s, s - 1)] -= c;
        }
    }
    Ok((&r + r.transpose()) * 0.5)
}

/// A square n x n matrix from rows; errors name `field` and the bad row.
pub fn matrix_from_rows(
    field: &str,
    rows: &[Vec<f64>],
    n: usize,
) -> Result<DMatrix<f64>, SimError> {
    if rows.len() != n {
        return Err(SimError::invalid(
            field,
            format!("has {} rows, expected {n}", rows.len()),
        ));
    }
    for (i, row) in rows.iter().enumerate() {
        if row.len() != n {
            return Err(SimError::invalid(
                format!("{field}[{i}]"),
                format!("has {} entries, expected {n}", row.len()),
            ));
        }
        if let Some(j) = row.iter().position(|v| !v.is_finite()) {
            return Err(SimError::invalid(
                format!("{field}[{i}][{j}]"),
                "is not a finite number",
            ));
        }
    }
    Ok(DMatrix::from_fn(n, n, |i, j| rows[i][j]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use approx::assert_relative_eq;

    fn mk() -> (DMatrix<f64>, DMatrix<f64>) {
        (
            DMatrix::from_row_slice(2, 2, &[1.4, 0.0, 0.0, 1.3]),
            DMatrix::from_row_slice(2, 2, &[1775.0, -686.0, -686.0, 686.0]),
        )
    }

    #[test]
    fn target_ratios_are_met() {
        let (m, k) = mk();
        let r = build_damping(
            &m,
            &k,
            &DampingSpec::TargetRatios {
                modes: [1, 2],
                ratios: [0.005, 0.003],
            },
            &[],
        )
        .unwrap();
        let modal = Model::new(m, k, r).unwrap().modal().unwrap();
        // Exact for proportional damping up to eigenvalue rounding.
        assert_relative_eq!(modal.damping_ratios[0], 0.005, max_relative = 1e-9);
        assert_relative_eq!(modal.damping_ratios[1], 0.003, max_relative = 1e-9);
    }

    #[test]
    fn modal_ratios_are_met_for_every_mode() {
        let m = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, 1.2, 0.9]));
        let k = crate::structure::chain_matrix(&[900.0, 700.0, 500.0]);
        let xi = vec![0.01, 0.004, 0.02];
        let r = build_damping(&m, &k, &DampingSpec::Modal { ratios: xi.clone() }, &[]).unwrap();
        let modal = Model::new(m, k, r).unwrap().modal().unwrap();
        for i in 0..3 {
            // Modal damping is proportional by construction: exact to rounding.
            assert_relative_eq!(modal.damping_ratios[i], xi[i], max_relative = 1e-9);
        }
    }

    #[test]
    fn dashpot_adds_a_storey_element_and_makes_modes_complex() {
        let (m, k) = mk();
        let spec = DampingSpec::Rayleigh {
            alpha: 0.1,
            beta: 1e-5,
        };
        let base = build_damping(&m, &k, &spec, &[]).unwrap();
        let with = build_damping(
            &m,
            &k,
            &spec,
            &[Dashpot {
                storey: 2,
                coefficient_ns_per_m: 0.5,
            }],
        )
        .unwrap();
        let diff = &with - &base;
        assert_relative_eq!(
            diff,
            DMatrix::from_row_slice(2, 2, &[0.5, -0.5, -0.5, 0.5]),
            epsilon = 1e-15
        );
        let modal = Model::new(m, k, with).unwrap().modal().unwrap();
        let im: f64 = modal.mode_shapes.iter().flatten().map(|c| c.im.abs()).sum();
        // Non-proportional damping gives visibly complex shapes (>> rounding).
        assert!(im > 1e-4, "shapes should be complex, sum |Im| = {im}");
    }

    #[test]
    fn bad_damping_fields_are_named() {
        let (m, k) = mk();
        let err =
            build_damping(&m, &k, &DampingSpec::Modal { ratios: vec![0.01] }, &[]).unwrap_err();
        assert_eq!(
            err.to_string(),
            "damping.ratios: 1 ratios given for 2 modes"
        );
        let err = build_damping(
            &m,
            &k,
            &DampingSpec::None,
            &[Dashpot {
                storey: 3,
                coefficient_ns_per_m: 1.0,
            }],
        )
        .unwrap_err();
        assert!(
            err.to_string()
                .starts_with("dashpots[0].storey: storey 3 does not exist")
        );
    }
}
