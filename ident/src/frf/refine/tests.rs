//! The FRF refinement against exact FRFs of shear frames (closed forms of
//! [`crate::frf::synth`], independent of the refinement code) and against its
//! own statistics (Monte Carlo).

use super::*;
use crate::frf::FrfIdentifier;
use crate::frf::synth::*;
use crate::refine::{Dashpot, Node};
use crate::testutil::normal;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

type System = (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>);

/// The paper's 2-DOF frame (full symmetric M, K and Rayleigh damping).
fn two_dof() -> System {
    testkit::paper_case1().into_parts()
}

/// The 3-storey frame of `synth` with non-proportional damping.
fn three_dof() -> System {
    let (m, k) = three_storey();
    let r = non_proportional(&m, &k);
    (m, k, r)
}

/// Shear frame with the ground dashpots mass-proportional damping needs.
fn shear_frame_3() -> Parametrization {
    Parametrization::ShearFrame {
        dashpots: vec![
            Dashpot::between(Node::Ground, Node::Dof(1)),
            Dashpot::between(Node::Ground, Node::Dof(2)),
        ],
    }
}

fn frf_of(system: &System, references: &[usize], quantity: FrfQuantity, df: f64) -> Frf {
    let (m, k, r) = system;
    let outputs: Vec<usize> = (0..m.nrows()).collect();
    exact_frf((m, k, r), &outputs, references, quantity, grid(df, 25.0))
}

/// Parameters of `system` under `parametrization`, checked representable.
fn truth_parameters(parametrization: &Parametrization, system: &System) -> DVector<f64> {
    let params = parametrization.parameters(system.0.nrows()).unwrap();
    let (theta, residuals) = param::project(&params, &system.0, &system.1, &system.2);
    // Representable exactly: projection residuals are round-off (measured below 1e-15).
    assert!(residuals.iter().all(|&x| x < 1e-12), "{residuals:?}");
    theta
}

/// `system` with every parameter scaled by `1 + relative * N(0, 1)`, damping
/// parameters by `damping_factor` on top.
fn perturbed(
    parametrization: &Parametrization,
    system: &System,
    relative: f64,
    damping_factor: f64,
    rng: &mut ChaCha8Rng,
) -> SecondOrder {
    let n = system.0.nrows();
    let params = parametrization.parameters(n).unwrap();
    let theta = truth_parameters(parametrization, system);
    let theta = DVector::from_fn(theta.len(), |p, _| {
        let f = if params[p].matrix == MatrixKind::Damping {
            damping_factor
        } else {
            1.0
        };
        theta[p] * f * (1.0 + relative * normal(rng))
    });
    let (m, k, r) = param::matrices(&params, &theta, n);
    SecondOrder::new(m, k, r)
}

fn errors(refined: &FrfRefinement, system: &System) -> (f64, f64, f64) {
    (
        linalg::relative_error(&refined.mass, &system.0),
        linalg::relative_error(&refined.stiffness, &system.1),
        linalg::relative_error(&refined.damping, &system.2),
    )
}

/// Circular complex noise of variance `variance(line, i, l)` on every value.
fn add_noise_with(
    frf: &mut Frf,
    variance: &dyn Fn(usize, usize, usize) -> f64,
    rng: &mut ChaCha8Rng,
) {
    for (k, h) in frf.values.iter_mut().enumerate() {
        for l in 0..h.ncols() {
            for i in 0..h.nrows() {
                let s = (variance(k, i, l) / 2.0).sqrt();
                h[(i, l)] += C64::new(s * normal(rng), s * normal(rng));
            }
        }
    }
}

/// Coherence of an H1 estimate with `averages` averages whose variance is
/// `variance`: `γ² = |H|^2 / (|H|^2 + (n_d - 1) V)`, so that
/// `(1 - γ²) |H|^2 / ((n_d - 1) γ²) = V` (the module's formula), with `H`
/// the values of `reference` (the noisy FRF itself for an analyzer's
/// self-consistent estimate, the clean one for a coherence that is off by
/// the noise).
fn coherence_for(
    reference: &Frf,
    variance: &dyn Fn(usize, usize, usize) -> f64,
    averages: usize,
) -> Vec<DMatrix<f64>> {
    reference
        .values
        .iter()
        .enumerate()
        .map(|(k, h)| {
            DMatrix::from_fn(h.nrows(), h.ncols(), |i, l| {
                let h2 = h[(i, l)].norm_sqr();
                h2 / (h2 + (averages - 1) as f64 * variance(k, i, l))
            })
        })
        .collect()
}

#[test]
fn gradient_matches_central_differences() {
    // The projected cost's gradient is 2 J^T r exactly (residual terms
    // eliminated; envelope theorem), with and without residual terms.
    let system = three_dof();
    let param = shear_frame_3();
    let mut frf = frf_of(&system, &[0, 1], FrfQuantity::Accelerance, 1.0 / 8.0);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let sigma = 0.02 * rms(&frf);
    add_noise(&mut frf, sigma, &mut rng);
    let start = FrfStart::new(perturbed(&param, &system, 0.02, 1.5, &mut rng), vec![0, 1]);
    for residuals in [
        ResidualTerms {
            lower: false,
            upper: false,
        },
        ResidualTerms {
            lower: true,
            upper: true,
        },
    ] {
        let refiner = FrfRefiner::default()
            .parametrization(param.clone())
            .residuals(residuals);
        let problem = refiner.problem(&frf, &start).unwrap();
        let params = &problem.params;
        let (theta, _) = param::project(
            params,
            &start.initial.mass,
            &start.initial.stiffness,
            &start.initial.damping,
        );
        let weights: Vec<DMatrix<f64>> = problem
            .lines
            .iter()
            .enumerate()
            .map(|(k, _)| DMatrix::from_fn(3, 2, |i, l| 1.0 + 0.1 * ((k + i + l) % 3) as f64))
            .collect();
        let ev = problem.evaluate(&theta, &weights, true, false).unwrap();
        let gradient = ev.gradient.unwrap();
        let mut worst: f64 = 0.0;
        for p in 0..theta.len() {
            let h = 1e-6 * theta[p].abs().max(1e-3);
            let mut plus = theta.clone();
            plus[p] += h;
            let mut minus = theta.clone();
            minus[p] -= h;
            let cp = problem
                .evaluate(&plus, &weights, false, false)
                .unwrap()
                .cost;
            let cm = problem
                .evaluate(&minus, &weights, false, false)
                .unwrap()
                .cost;
            let fd = (cp - cm) / (2.0 * h);
            let scale = 2.0 * gradient[p].abs().max(1e-3 * gradient.amax());
            worst = worst.max((fd - 2.0 * gradient[p]).abs() / scale);
        }
        println!("{residuals:?}: gradient error {worst:.1e}");
        // Central differences with 1e-6 relative steps on a cost of ~1e5:
        // truncation ~1e-12 relative, round-off ~eps cost / (h g) ~1e-8;
        // measured up to 1e-8. A wrong term (e.g. the derivative of one
        // matrix kind off by a sign) gives O(1).
        assert!(worst < 1e-5, "gradient error {worst:e}");
    }
}

#[test]
fn noise_free_frfs_give_the_frame_from_a_perturbed_start() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let cases = [
        (
            "2-DOF, full, accelerance, 1 reference",
            two_dof(),
            Parametrization::Full,
            vec![0],
            FrfQuantity::Accelerance,
        ),
        (
            "2-DOF, full, receptance, 2 references",
            two_dof(),
            Parametrization::Full,
            vec![0, 1],
            FrfQuantity::Receptance,
        ),
        (
            "3-DOF, shear frame, accelerance, 2 references",
            three_dof(),
            shear_frame_3(),
            vec![0, 1],
            FrfQuantity::Accelerance,
        ),
        (
            "3-DOF, full, mobility, 1 reference",
            three_dof(),
            Parametrization::Full,
            vec![2],
            FrfQuantity::Mobility,
        ),
    ];
    for (name, system, param, refs, quantity) in cases {
        let frf = frf_of(&system, &refs, quantity, 1.0 / 32.0);
        // M and K parameters 2 % off (first frequency up to ~3 % off), damping x2.
        let start = FrfStart::new(perturbed(&param, &system, 0.02, 2.0, &mut rng), refs);
        let refined = FrfRefiner::default()
            .parametrization(param)
            .refine(&frf, &start)
            .unwrap();
        let (em, ek, ec) = errors(&refined, &system);
        println!(
            "{name}: M {em:.1e}, K {ek:.1e}, damping {ec:.1e}, {} iterations, {}",
            refined.iterations, refined.stop
        );
        // Exact data and model: the estimate is the truth up to round-off
        // amplified by the conditioning of the fit. Measured M, K 1e-12 to
        // 1e-10 and damping 1e-11 to 1e-9 (damping is the small imaginary
        // part of the dynamic stiffness), hence 1e-8.
        assert!(em < 1e-8 && ek < 1e-8 && ec < 1e-8, "{name}");
        assert!(refined.stop.converged(), "{name}: {}", refined.stop);
        assert!(refined.cost < 1e-6 * refined.initial_cost, "{name}");
        assert!(
            refined.warnings.is_empty(),
            "{name}: {:?}",
            refined.warnings
        );
        // The upper residual of an exact n-DOF model is 0 (relative to the
        // quantity's level; measured round-off).
        assert_eq!(refined.residual_powers.len(), 1);
    }
}
