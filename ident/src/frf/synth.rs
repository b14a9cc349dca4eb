//! Exact FRFs of shear frames for the tests, built from M, K and damping
//! independently of the identification code.

use super::{Frf, FrfQuantity};
use crate::linalg::{self, C64};
use crate::testutil::normal;
use nalgebra::DMatrix;
use rand::rngs::ChaCha8Rng;
use std::f64::consts::PI;

/// A 3-storey frame of the paper's scale: modes at 3.09, 7.80 and 11.23 Hz
/// with [`non_proportional`] damping (3.04, 7.80, 11.23 with Rayleigh).
pub fn three_storey() -> (DMatrix<f64>, DMatrix<f64>) {
    let frame = testkit::ShearFrame::lumped(&[0.30, 0.28, 0.25], &[600.0, 450.0, 350.0]);
    (frame.mass, frame.stiffness)
}

/// Rayleigh damping `0.15 M + 4e-5 K`.
pub fn rayleigh(m: &DMatrix<f64>, k: &DMatrix<f64>) -> DMatrix<f64> {
    testkit::ShearFrame::undamped(m.clone(), k.clone())
        .rayleigh(0.15, 4e-5)
        .damping
}

/// Rayleigh damping plus a 0.3 N s/m dashpot from floor 1 to the ground:
/// not proportional, complex modes.
pub fn non_proportional(m: &DMatrix<f64>, k: &DMatrix<f64>) -> DMatrix<f64> {
    testkit::ShearFrame::undamped(m.clone(), k.clone())
        .rayleigh(0.15, 4e-5)
        .storey_dashpot(1, 0.3)
        .damping
}

/// Exact FRFs `(i w)^q (K - w^2 M + i w damping)^-1`, forces at the DOFs
/// `references`, responses at the DOFs `outputs`.
pub fn exact_frf(
    system: (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>),
    outputs: &[usize],
    references: &[usize],
    quantity: FrfQuantity,
    frequency_hz: Vec<f64>,
) -> Frf {
    windowed_frf(system, outputs, references, quantity, frequency_hz, 0.0)
}

/// As [`exact_frf`], of records multiplied by `exp(-t / tau)` (`decay =
/// 1 / tau`, 1/s): `H(s + decay)` at `s = i w`, with `s' = i w + decay` in
/// `(s')^q (K + s'^2 M + s' damping)^-1`.
pub fn windowed_frf(
    system: (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>),
    outputs: &[usize],
    references: &[usize],
    quantity: FrfQuantity,
    frequency_hz: Vec<f64>,
    decay: f64,
) -> Frf {
    let (mass, stiffness, damping) = system;
    let n = mass.nrows();
    let values = frequency_hz
        .iter()
        .map(|&f| {
            let s = C64::new(decay, 2.0 * PI * f);
            let z = DMatrix::from_fn(n, n, |i, j| {
                s * s * mass[(i, j)] + s * damping[(i, j)] + stiffness[(i, j)]
            });
            let h = z
                .lu()
                .try_inverse()
                .expect("dynamic stiffness is invertible");
            let factor = s.powi(quantity.derivative_order());
            DMatrix::from_fn(outputs.len(), references.len(), |i, j| {
                h[(outputs[i], references[j])] * factor
            })
        })
        .collect();
    Frf {
        frequency_hz,
        values,
        quantity,
        coherence: None,
        averages: None,
        outputs: outputs.iter().map(|i| format!("floor {}", i + 1)).collect(),
        references: references
            .iter()
            .map(|i| format!("force {}", i + 1))
            .collect(),
    }
}

/// True poles (`Im > 0`, ascending) and receptance residues (all DOFs x
/// references) from the eigenvectors of the first-order state matrix:
/// `R_j = [I 0] v_j (V^-1 [0; M^-1 B2])_j`.
pub fn true_modes(
    mass: &DMatrix<f64>,
    stiffness: &DMatrix<f64>,
    damping: &DMatrix<f64>,
    references: &[usize],
) -> Vec<(C64, DMatrix<C64>)> {
    let n = mass.nrows();
    let mi = mass.clone().try_inverse().expect("M is invertible");
    let mut a = DMatrix::zeros(2 * n, 2 * n);
    a.view_mut((0, n), (n, n))
        .copy_from(&DMatrix::identity(n, n));
    a.view_mut((n, 0), (n, n)).copy_from(&-(&mi * stiffness));
    a.view_mut((n, n), (n, n)).copy_from(&-(&mi * damping));
    let mut b = DMatrix::<f64>::zeros(2 * n, references.len());
    for (j, &r) in references.iter().enumerate() {
        b.view_mut((n, j), (n, 1)).copy_from(&mi.column(r));
    }
    let eig = linalg::eig(&a).expect("state matrix eigenvalues");
    let vinv = eig
        .vectors
        .clone()
        .try_inverse()
        .expect("distinct eigenvalues");
    let bm = &vinv * b.map(|x| C64::new(x, 0.0));
    let mut modes: Vec<(C64, DMatrix<C64>)> = (0..2 * n)
        .filter(|&j| eig.values[j].im > 0.0)
        .map(|j| {
            let v = eig.vectors.view((0, j), (n, 1)).into_owned();
            (eig.values[j], v * bm.row(j))
        })
        .collect();
    modes.sort_by(|x, y| x.0.im.total_cmp(&y.0.im));
    modes
}

/// Natural frequency of a pole, Hz.
pub fn frequency_hz(pole: C64) -> f64 {
    pole.norm() / (2.0 * PI)
}

/// Damping ratio of a pole.
pub fn damping_ratio(pole: C64) -> f64 {
    -pole.re / pole.norm()
}

/// Analyzer grid: 0 to `f_max` Hz every `df` Hz.
pub fn grid(df: f64, f_max: f64) -> Vec<f64> {
    (0..=(f_max / df).round() as usize)
        .map(|k| k as f64 * df)
        .collect()
}

/// Adds circular complex Gaussian noise of standard deviation `sigma`
/// (`E|n|^2 = sigma^2`) to every value.
pub fn add_noise(frf: &mut Frf, sigma: f64, rng: &mut ChaCha8Rng) {
    let s = sigma / 2f64.sqrt();
    for h in &mut frf.values {
        for z in h.iter_mut() {
            *z += C64::new(s * normal(rng), s * normal(rng));
        }
    }
}

/// RMS of |H| over all lines and entries.
pub fn rms(frf: &Frf) -> f64 {
    let n = frf.lines() * frf.outputs_count() * frf.references_count();
    (frf.values.iter().map(|h| h.norm_squared()).sum::<f64>() / n as f64).sqrt()
}
