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

/// An analyzer's H1 estimate of `clean`, emulated line by line from its
/// definition: per line and reference, `n_d` independent force spectra `X_i
/// ~ CN(0, 1)` (one test per reference), responses `Y_i = H X_i + N_i` with
/// circular noise of variance `noise(line, output, reference)`, then `Ĥ =
/// Ĝ_xy / Ĝ_xx` and `γ² = |Ĝ_xy|^2 / (Ĝ_xx Ĝ_yy)`. Independent of the
/// module's variance formula, which it tests.
fn h1_estimate(
    clean: &Frf,
    noise: &dyn Fn(usize, usize, usize) -> f64,
    averages: usize,
    rng: &mut ChaCha8Rng,
) -> Frf {
    let mut frf = clean.clone();
    let mut coherence = Vec::with_capacity(clean.lines());
    let cn = |rng: &mut ChaCha8Rng, var: f64| {
        let s = (var / 2.0).sqrt();
        C64::new(s * normal(rng), s * normal(rng))
    };
    for (k, h) in clean.values.iter().enumerate() {
        let (m, r) = h.shape();
        let mut coh = DMatrix::zeros(m, r);
        for l in 0..r {
            let x: Vec<C64> = (0..averages).map(|_| cn(rng, 1.0)).collect();
            let gxx: f64 = x.iter().map(|v| v.norm_sqr()).sum::<f64>() / averages as f64;
            for i in 0..m {
                let var = noise(k, i, l);
                let y: Vec<C64> = x.iter().map(|&xi| h[(i, l)] * xi + cn(rng, var)).collect();
                let gyy: f64 = y.iter().map(|v| v.norm_sqr()).sum::<f64>() / averages as f64;
                let gxy: C64 =
                    y.iter().zip(&x).map(|(yi, xi)| yi * xi.conj()).sum::<C64>() / averages as f64;
                frf.values[k][(i, l)] = gxy / gxx;
                coh[(i, l)] = gxy.norm_sqr() / (gxx * gyy);
            }
        }
        coherence.push(coh);
    }
    frf.coherence = Some(coherence);
    frf.averages = Some(averages);
    frf
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

/// Monte Carlo of `replicates` refinements of `clean` plus noise drawn by
/// `noisy`: per parameter the mean error over its standard error of the
/// mean (`z` of the bias) and the sample standard deviation over the mean
/// predicted standard error; also the mean cost over its expectation.
fn monte_carlo(
    system: &System,
    param: &Parametrization,
    refiner: &FrfRefiner,
    refs: &[usize],
    replicates: usize,
    noisy: &mut dyn FnMut(&mut ChaCha8Rng) -> Frf,
    seed: u64,
) -> (Vec<f64>, Vec<f64>, f64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = truth_parameters(param, system);
    let np = truth.len();
    let start = FrfStart::new(
        SecondOrder::new(system.0.clone(), system.1.clone(), system.2.clone()),
        refs.to_vec(),
    );
    let mut sum = DVector::<f64>::zeros(np);
    let mut sum2 = DVector::<f64>::zeros(np);
    let mut predicted = DVector::<f64>::zeros(np);
    let mut cost_ratio = 0.0;
    for _ in 0..replicates {
        let frf = noisy(&mut rng);
        let refined = refiner.refine(&frf, &start).unwrap();
        assert!(refined.stop.converged(), "{}", refined.stop);
        let e = &refined.parameters - &truth;
        sum += &e;
        sum2 += e.component_mul(&e);
        predicted += &refined.uncertainty.parameter_std;
        cost_ratio += refined.cost / (refined.observations - refined.unknowns) as f64;
    }
    let nr = replicates as f64;
    let mean = sum / nr;
    let predicted = predicted / nr;
    let var = (sum2 / nr - mean.component_mul(&mean)) * (nr / (nr - 1.0));
    let bias_z = (0..np)
        .map(|p| mean[p] / (predicted[p] / nr.sqrt()))
        .collect();
    let std_ratio = (0..np).map(|p| var[p].sqrt() / predicted[p]).collect();
    (bias_z, std_ratio, cost_ratio / nr)
}

#[test]
fn monte_carlo_with_estimated_noise_matches_the_standard_errors() {
    // 2-DOF frame, full parametrization (9 parameters), accelerance at
    // floors 1 and 2 from floor 1, 0.5 to 25 Hz every 1/32 Hz (785 lines),
    // circular noise of 1 % of the RMS on every value; one variance per
    // output estimated (concentrated likelihood), upper residual term.
    let system = two_dof();
    let param = Parametrization::Full;
    let clean = frf_of(&system, &[0], FrfQuantity::Accelerance, 1.0 / 32.0);
    let sigma = 0.01 * rms(&clean);
    let refiner = FrfRefiner::default()
        .parametrization(param.clone())
        .band_hz(0.5, 25.0);
    let replicates = 200;
    let (bias_z, std_ratio, cost_ratio) = monte_carlo(
        &system,
        &param,
        &refiner,
        &[0],
        replicates,
        &mut |rng| {
            let mut frf = clean.clone();
            add_noise(&mut frf, sigma, rng);
            frf
        },
        5,
    );
    println!("bias z {bias_z:.2?}\nstd ratio {std_ratio:.3?}\ncost ratio {cost_ratio:.4}");
    // Mean error within 4 standard errors of the mean for each of the 9
    // parameters (a 4-sigma bound keeps the family-wise false alarm rate of
    // 9 parameters near 6e-4). Measured |z| up to 2.2 here; with 2000
    // replicates (seeds 1 and 2) |z| up to 1.9, no sign pattern: the bias
    // (second order in the noise) is below 0.05 standard errors.
    assert!(bias_z.iter().all(|z| z.abs() < 4.0), "{bias_z:?}");
    // The sample standard deviation of 200 replicates has a relative
    // standard deviation of 1 / sqrt(2 * 199) = 0.050 (chi-square with 199
    // degrees of freedom); 4 of those is 0.2. Measured ratios 0.92 to 1.08;
    // with 2000 replicates 0.97 to 1.03 (sampling: 0.016).
    assert!(
        std_ratio.iter().all(|r| (r - 1.0).abs() < 0.2),
        "{std_ratio:?}"
    );
    // With the variances estimated and corrected for the degrees of freedom,
    // the cost equals its expectation by construction, up to the change of
    // the last noise update (measured 0.9999; 2e-2 allows a last update of
    // 2 %, the alternation converges far faster).
    assert!((cost_ratio - 1.0).abs() < 0.02, "{cost_ratio}");
}

#[test]
fn monte_carlo_with_coherence_and_averages_matches_the_standard_errors() {
    // H1 estimates of 8 averages emulated from their definition
    // (`h1_estimate`): noise of 2 % of |H| (the peaks are noisier) plus a
    // floor of 0.2 % of the RMS, in the variance of the estimate (the noise
    // spectrum is n_d times that for unit force spectra). Nothing is
    // estimated: the weights are the module's (1 - γ²)|Ĥ|²/((n_d - 1) γ²).
    let system = two_dof();
    let param = Parametrization::Full;
    let clean = frf_of(&system, &[0], FrfQuantity::Accelerance, 1.0 / 32.0);
    let floor = 0.002 * rms(&clean);
    let averages = 8;
    let noise = |k: usize, i: usize, l: usize| {
        averages as f64 * ((0.02 * 0.02) * clean.values[k][(i, l)].norm_sqr() + floor * floor)
    };
    let refiner = FrfRefiner::default()
        .parametrization(param.clone())
        .band_hz(0.5, 25.0);
    let replicates = 200;
    let (bias_z, std_ratio, cost_ratio) = monte_carlo(
        &system,
        &param,
        &refiner,
        &[0],
        replicates,
        &mut |rng| h1_estimate(&clean, &noise, averages, rng),
        6,
    );
    println!("bias z {bias_z:.2?}\nstd ratio {std_ratio:.3?}\ncost ratio {cost_ratio:.4}");
    // As in the test above: |z| below 4 and the ratios within 0.2 of 1.
    // The standard errors include the factor sqrt(nu / (nu - 2)) = 1.18 of
    // the noisy weights (nu = 7): without it the ratios would be about 1.18.
    // Measured |z| up to 1.8, ratios 0.99 to 1.09; with 1000 replicates
    // (seed 16) |z| up to 1.9 and ratios 0.96 to 1.02 (sampling: 0.022).
    assert!(bias_z.iter().all(|z| z.abs() < 4.0), "{bias_z:?}");
    assert!(
        std_ratio.iter().all(|r| (r - 1.0).abs() < 0.2),
        "{std_ratio:?}"
    );
    // The cost's expectation is nu / (nu - 1) = 7 / 6 times observations -
    // unknowns (3140 - 11). Per complex value the cost is chi2(2) / u with
    // mean 2 E[1/u] = 2.33 and standard deviation 2.8, so one cost has a
    // relative standard deviation of 2.8 / 2.33 / sqrt(1570) = 0.030 and the
    // mean of 200 costs 0.0021; 4 of those is 0.009. Measured 1.1633, and
    // 1.1659 with 1000 replicates (7 / 6 = 1.1667).
    let expected = 7.0 / 6.0;
    assert!((cost_ratio / expected - 1.0).abs() < 0.009, "{cost_ratio}");
}
