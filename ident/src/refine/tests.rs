//! Unit tests of the refinement internals: exact derivatives against central differences,
//! and the Fisher information against a closed form and a brute-force time-domain one.

use super::likelihood::{self, Noise, Want};
use super::model::{Model, expm_frechet};
use super::spectra::{self, Spectra};
use super::uncertainty;
use super::*;
use crate::testutil::normal;
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

const DT: f64 = 1.0 / 64.0;

/// Mass, stiffness and damping matrices.
type Matrices = (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>);

fn three_storeys() -> Matrices {
    // Rayleigh plus an extra dashpot across storey 2, between floors 1 and 2
    // (non-proportional).
    testkit::ShearFrame::lumped(&[1.0, 0.9, 0.8], &[1000.0, 900.0, 800.0])
        .rayleigh(0.12, 1.5e-4)
        .storey_dashpot(2, 0.3)
        .into_parts()
}

/// Records of white-noise force at DOF 0 through the exact held model, plus noise on every
/// channel: data for derivative checks (their origin does not matter, a nonzero residual
/// does).
fn random_records(
    model: &Model,
    rng: &mut ChaCha8Rng,
    hits: usize,
    len: usize,
    noise: f64,
) -> Vec<Record> {
    (0..hits)
        .map(|_| {
            let u = DMatrix::from_fn(model.r, len, |_, _| normal(rng));
            let mut y = spectra::noise_free_outputs(model, std::slice::from_ref(&u)).remove(0);
            let rms = (y.norm_squared() / y.len() as f64).sqrt();
            y.iter_mut().for_each(|v| *v += noise * rms * normal(rng));
            let u = u.map(|v| v + noise * normal(rng));
            Record::new(u, y)
        })
        .collect()
}

fn held_model(m: &DMatrix<f64>, k: &DMatrix<f64>, r: &DMatrix<f64>) -> Model {
    held_model_with_inputs(m, k, r, &[0])
}

/// Held model with forces at `dofs`.
fn held_model_with_inputs(
    m: &DMatrix<f64>,
    k: &DMatrix<f64>,
    r: &DMatrix<f64>,
    dofs: &[usize],
) -> Model {
    let mut b2 = DMatrix::zeros(m.nrows(), dofs.len());
    for (l, &dof) in dofs.iter().enumerate() {
        b2[(dof, l)] = 1.0;
    }
    Model::new(m, k, r, &b2, DT, Intersample::Zoh, None).unwrap()
}

#[test]
fn frechet_derivative_of_the_exponential() {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let model = held_model(&m, &k, &r);
    let x = &model.a * DT;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let e = DMatrix::from_fn(4, 4, |_, _| normal(&mut rng));
    let (ex, l) = expm_frechet(&x, &e);
    assert!((&ex - x.exp()).norm() < 1e-14 * ex.norm());
    let h = 1e-5;
    let fd = ((&x + &e * h).exp() - (&x - &e * h).exp()) / (2.0 * h);
    // Central difference: truncation ~h^2 |x|^2 |e| ~ 1e-10, round-off ~eps / h ~ 1e-11.
    assert!(
        (&l - &fd).norm() < 1e-8 * l.norm(),
        "{}",
        (&l - &fd).norm() / l.norm()
    );
}

/// Step for a central difference of parameter `p`: relative to the parameter, or to the
/// largest parameter of the same matrix for entries near zero.
fn step(problem: &Problem, theta: &DVector<f64>, p: usize) -> f64 {
    let kind = problem.params[p].matrix;
    let typical = (0..theta.len())
        .filter(|&q| problem.params[q].matrix == kind)
        .map(|q| theta[q].abs())
        .fold(0.0, f64::max);
    1e-5 * theta[p].abs().max(1e-2 * typical)
}

/// The residual at `theta` with the transients fixed to `xi`, in the coordinates of the
/// evaluations' transient regressors ([`likelihood::HitMatrices::xi`]: the eigenbasis' for
/// band-limited models, whose normalization is smooth in the parameters).
fn residual_at_fixed_xi(
    problem: &Problem,
    theta: &DVector<f64>,
    noise: &Noise,
    xi: &[DVector<f64>],
) -> Vec<DVector<f64>> {
    let ev = problem.evaluate(theta, noise, Want::Cost, false).unwrap();
    ev.matrices
        .iter()
        .zip(xi)
        .map(|(hm, fixed)| &hm.r0 - &hm.x * fixed)
        .collect()
}

fn check_jacobian(
    intersample: Intersample,
    parametrization: Parametrization,
    truth: Matrices,
    seed: u64,
) {
    check_jacobian_with_inputs(intersample, parametrization, truth, seed, &[0]);
}

/// [`check_jacobian_with_inputs_in`] in the eigenbasis form of the transient (where the model
/// takes it) and in the resolvent form.
fn check_jacobian_with_inputs(
    intersample: Intersample,
    parametrization: Parametrization,
    truth: Matrices,
    seed: u64,
    input_dofs: &[usize],
) {
    for eigenbasis in [true, false] {
        with_setting(&likelihood::EIGENBASIS, eigenbasis, || {
            let before = likelihood::EIGENBASIS_EVALUATIONS.with(|c| c.get());
            check_jacobian_with_inputs_in(
                intersample,
                parametrization.clone(),
                truth.clone(),
                seed,
                input_dofs,
            );
            let used = likelihood::EIGENBASIS_EVALUATIONS.with(|c| c.get()) - before;
            // Band-limited models of lightly damped frames take the eigenbasis.
            let expected = eigenbasis && intersample == Intersample::Bandlimited;
            assert_eq!(
                used > 0,
                expected,
                "{intersample:?}, eigenbasis {eigenbasis}"
            );
        });
    }
}

fn check_jacobian_with_inputs_in(
    intersample: Intersample,
    parametrization: Parametrization,
    truth: Matrices,
    seed: u64,
    input_dofs: &[usize],
) {
    let (m, k, r) = truth;
    let n = m.nrows();
    let inputs = input_dofs.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let data_model = held_model_with_inputs(&m, &k, &r, input_dofs);
    let records = random_records(&data_model, &mut rng, 3, 256, 0.05);
    let refiner = Refiner::default()
        .intersample(intersample)
        .parametrization(parametrization)
        .input_dofs(input_dofs.to_vec());
    let problem = refiner.problem(&records, DT, n).unwrap();
    let (theta_true, _) = param::project(&problem.params, &m, &k, &r);
    // Away from the data's model so that the residual (which multiplies the weight
    // derivative) is large.
    let theta = theta_true.map(|v| v * (1.0 + 0.02 * normal(&mut rng)));
    for noise in [
        Noise {
            outputs: vec![0.3; n],
            inputs: vec![0.0; inputs],
        },
        Noise {
            outputs: (0..n).map(|i| 0.2 + 0.1 * i as f64).collect(),
            inputs: (0..inputs).map(|l| 0.05 + 0.02 * l as f64).collect(),
        },
    ] {
        let ev = problem
            .evaluate(
                &theta,
                &noise,
                Want::Jacobian {
                    weight_derivative: true,
                },
                false,
            )
            .unwrap();
        let gradient = ev.gradient.clone().unwrap();
        // Without the weight's derivative (the expected-Fisher Jacobian): must differ when
        // the force is noisy, showing the check can see a missing term.
        let expected = problem
            .evaluate(
                &theta,
                &noise,
                Want::Jacobian {
                    weight_derivative: false,
                },
                false,
            )
            .unwrap();
        // Both matrices from one pass: bit for bit those of the two separate evaluations.
        let both = problem
            .evaluate(&theta, &noise, Want::JacobianAndFisher, false)
            .unwrap();
        assert_eq!(both.fisher, ev.fisher);
        assert_eq!(both.gradient, ev.gradient);
        assert_eq!(both.expected_fisher, expected.fisher);
        assert_eq!(both.cost.to_bits(), ev.cost.to_bits());
        let mut worst: f64 = 0.0;
        let mut worst_expected: f64 = 0.0;
        let mut worst_gradient: f64 = 0.0;
        for p in 0..theta.len() {
            let h = step(&problem, &theta, p);
            let mut plus = theta.clone();
            plus[p] += h;
            let mut minus = theta.clone();
            minus[p] -= h;
            let fixed: Vec<DVector<f64>> = ev.matrices.iter().map(|hm| hm.xi.clone()).collect();
            let rp = residual_at_fixed_xi(&problem, &plus, &noise, &fixed);
            let rm = residual_at_fixed_xi(&problem, &minus, &noise, &fixed);
            let (mut num, mut num_expected, mut den) = (0.0, 0.0, 0.0);
            for (hit, hm) in ev.matrices.iter().enumerate() {
                let analytic = hm.j.as_ref().unwrap().column(p).into_owned();
                let fd = (&rp[hit] - &rm[hit]) / (2.0 * h);
                num += (&analytic - &fd).norm_squared();
                num_expected +=
                    (expected.matrices[hit].j.as_ref().unwrap().column(p) - &fd).norm_squared();
                den += analytic.norm_squared();
            }
            worst = worst.max((num / den).sqrt());
            worst_expected = worst_expected.max((num_expected / den).sqrt());
            // The projected cost's gradient is 2 J^T r exactly (envelope theorem).
            let cp = problem
                .evaluate(&plus, &noise, Want::Cost, false)
                .unwrap()
                .cost;
            let cm = problem
                .evaluate(&minus, &noise, Want::Cost, false)
                .unwrap()
                .cost;
            let fd = (cp - cm) / (2.0 * h);
            let scale = 2.0 * gradient[p].abs().max(1e-3 * gradient.amax());
            worst_gradient = worst_gradient.max((fd - 2.0 * gradient[p]).abs() / scale);
        }
        println!(
            "{intersample:?} {n} DOF, sigma_u = {}: Jacobian {worst:.1e}, gradient {worst_gradient:.1e}, without the weight derivative {worst_expected:.1e}",
            noise.inputs[0]
        );
        // Central differences with 1e-5 relative steps: measured errors up to 6e-7, mostly
        // round-off of the model (~1e-11 relative, the conditioning of z I - A_d near the
        // resonances) over the step. A wrong or missing term is far larger (the missing
        // weight derivative: 0.17 to 1.3 here).
        assert!(worst < 1e-5, "Jacobian error {worst:e}");
        assert!(worst_gradient < 1e-4, "gradient error {worst_gradient:e}");
        if noise.inputs[0] > 0.0 {
            assert!(worst_expected > 1e-3, "{worst_expected:e}");
        }
    }
}

#[test]
fn jacobian_matches_central_differences_held_2dof() {
    check_jacobian(
        Intersample::Zoh,
        Parametrization::Full,
        testkit::paper_case1().into_parts(),
        11,
    );
}

#[test]
fn jacobian_matches_central_differences_held_3dof() {
    check_jacobian(Intersample::Zoh, Parametrization::Full, three_storeys(), 12);
    check_jacobian(
        Intersample::Zoh,
        Parametrization::ShearFrame {
            dashpots: vec![
                Dashpot::between(Node::Ground, Node::Dof(1)),
                Dashpot::between(Node::Dof(0), Node::Dof(2)),
            ],
        },
        three_storeys(),
        13,
    );
}

/// Two forces (at both DOFs): the errors-in-variables weight is a rank-2 update.
#[test]
fn jacobian_matches_central_differences_two_inputs() {
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        check_jacobian_with_inputs(
            intersample,
            Parametrization::Full,
            testkit::paper_case1().into_parts(),
            17,
            &[0, 1],
        );
    }
}

/// Two forces, noise-free held records: the refinement recovers the model.
#[test]
fn two_inputs_noise_free_round_trip() {
    let (m, k, r) = three_storeys();
    let dofs = [0, 2];
    let model = held_model_with_inputs(&m, &k, &r, &dofs);
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    let records = random_records(&model, &mut rng, 2, 512, 0.0);
    let start = SecondOrder::new(&m * 1.01, &k * 0.99, &r * 2.0);
    let refined = Refiner::default()
        .intersample(Intersample::Zoh)
        .input_dofs(dofs.to_vec())
        .refine(&records, DT, &start)
        .unwrap();
    let err = [
        linalg::relative_error(&refined.mass, &m),
        linalg::relative_error(&refined.stiffness, &k),
        linalg::relative_error(&refined.damping, &r),
    ];
    println!(
        "two inputs: M {:.1e} K {:.1e} damping {:.1e}, {}",
        err[0], err[1], err[2], refined.stop
    );
    // Exact model, noise-free data: round-off (measured 2e-15 to 1e-13).
    assert!(err.iter().all(|&e| e < 1e-8), "{err:?}");
}

#[test]
fn jacobian_matches_central_differences_bandlimited_2dof() {
    check_jacobian(
        Intersample::Bandlimited,
        Parametrization::Full,
        testkit::paper_case1().into_parts(),
        14,
    );
}

#[test]
fn jacobian_matches_central_differences_bandlimited_3dof() {
    check_jacobian(
        Intersample::Bandlimited,
        Parametrization::Full,
        three_storeys(),
        15,
    );
    check_jacobian(
        Intersample::Bandlimited,
        Parametrization::shear_frame(),
        three_storeys(),
        16,
    );
}

/// `sum_{t=0}^{N-1} t^k w^t` for k = 0, 1, 2 in closed form.
fn power_sum(w: C64, len: usize, k: usize) -> C64 {
    let one = C64::new(1.0, 0.0);
    let nf = len as f64;
    let wn = w.powu(len as u32);
    match k {
        0 => (one - wn) / (one - w),
        1 => w * (one - w.powu(len as u32 - 1) * nf + wn * (nf - 1.0)) / (one - w).powu(2),
        2 => {
            (w * (one + w)
                - wn * (w * w * (nf - 1.0).powi(2) - w * (2.0 * nf * nf - 2.0 * nf - 1.0)
                    + nf * nf))
                / (one - w).powu(3)
        }
        _ => unreachable!(),
    }
}

/// Fisher information of a damped sinusoid `y_t = Re(a x^t)`, `x = exp((-alpha + j omega)
/// dt)`, `a = P - j Q`, observed for `t = 0..N-1` in white noise `sigma`, for
/// `(omega, alpha)` with the amplitude and phase `(P, Q)` unknown (eliminated), in closed
/// form: every entry is `1/2 Re(a_i a_j S(x^2) + a_i conj(a_j) S(|x|^2)) / sigma^2` with
/// the closed-form power sums `S`.
fn damped_sinusoid_fisher(
    p: f64,
    q: f64,
    omega: f64,
    alpha: f64,
    dt: f64,
    len: usize,
    sigma: f64,
) -> DMatrix<f64> {
    let x = C64::new(-alpha * dt, omega * dt).exp();
    let a = C64::new(p, -q);
    let j = C64::new(0.0, 1.0);
    // (coefficient, power of t): d/domega, d/dalpha, d/dP, d/dQ.
    let terms = [
        (j * dt * a, 1),
        (-a * dt, 1),
        (C64::new(1.0, 0.0), 0),
        (-j, 0),
    ];
    let full = DMatrix::from_fn(4, 4, |i, k| {
        let (ai, pi) = terms[i];
        let (ak, pk) = terms[k];
        let s2 = power_sum(x * x, len, pi + pk);
        let s0 = power_sum(C64::new(x.norm_sqr(), 0.0), len, pi + pk);
        0.5 * (ai * ak * s2 + ai * ak.conj() * s0).re / (sigma * sigma)
    });
    let a11 = full.view((0, 0), (2, 2));
    let a12 = full.view((0, 2), (2, 2));
    let a22 = full.view((2, 2), (2, 2)).into_owned();
    a11 - a12 * a22.try_inverse().unwrap() * a12.transpose()
}

/// The Fisher information of the refinement's likelihood (DFT, bin weights, transient
/// elimination, Frechet derivatives of the transient) for a single-DOF free decay equals
/// the closed-form bound of a damped sinusoid with unknown amplitude and phase.
#[test]
fn fisher_of_a_free_decay_matches_the_closed_form() {
    let (mass, stiffness, damping) = (0.5, 200.0, 0.4);
    let len = 1024;
    let sigma = 0.01;
    let m = DMatrix::from_element(1, 1, mass);
    let k = DMatrix::from_element(1, 1, stiffness);
    let r = DMatrix::from_element(1, 1, damping);
    let model = held_model(&m, &k, &r);
    // Free decay from a displacement and a velocity.
    let x0 = DVector::from_vec(vec![0.01, -0.05]);
    let ad = model.ad.map(|z| z.re);
    let c = model.c.map(|z| z.re);
    let mut x = x0.clone();
    let mut y = DMatrix::zeros(1, len);
    for t in 0..len {
        y[(0, t)] = (&c * &x)[0];
        x = &ad * x;
    }
    let records = vec![Record::new(DMatrix::zeros(1, len), y)];
    let params = Parametrization::shear_frame().parameters(1).unwrap();
    let spectra = Spectra::new(&records, DT, Intersample::Zoh, 1.0);
    let problem = Problem {
        observations: likelihood::observations(&spectra, 1),
        unknowns: 3 + 2,
        params,
        b2: DMatrix::from_element(1, 1, 1.0),
        spectra,
        dt: DT,
        intersample: Intersample::Zoh,
        n: 1,
        r: 1,
        memo: Default::default(),
    };
    let theta = DVector::from_vec(vec![mass, stiffness, damping]);
    let noise = Noise {
        outputs: vec![sigma],
        inputs: vec![0.0],
    };
    let ev = problem
        .evaluate(
            &theta,
            &noise,
            Want::Jacobian {
                weight_derivative: false,
            },
            false,
        )
        .unwrap();
    // Noise-free data: the transient fits to round-off.
    assert!(ev.cost < 1e-20, "cost {}", ev.cost);
    let fisher = ev.fisher.unwrap();
    // A free decay says nothing about the scale of (m, k, c): only k and c with m known.
    let kc = fisher.view((1, 1), (2, 2)).into_owned();

    let alpha = damping / (2.0 * mass);
    let omega = (stiffness / mass - alpha * alpha).sqrt();
    // y(0) = P, y'(0) = -alpha P + omega Q.
    let p = (&c * &x0)[0];
    let q = ((&c * &model.a * &x0)[0] + alpha * p) / omega;
    let closed = damped_sinusoid_fisher(p, q, omega, alpha, DT, len, sigma);
    // (omega, alpha) as functions of (k, c) at fixed m.
    let jac = DMatrix::from_row_slice(
        2,
        2,
        &[
            1.0 / (2.0 * mass * omega),
            -alpha / (2.0 * mass * omega),
            0.0,
            1.0 / (2.0 * mass),
        ],
    );
    let expected = jac.transpose() * closed * jac;
    let err = (&kc - &expected).norm() / expected.norm();
    println!("free decay Fisher: relative difference {err:.2e}");
    // Both sides are exact; what remains is round-off of FFTs, exponentials and a 2x2
    // Schur complement (measured ~1e-13).
    assert!(err < 1e-10, "{kc} vs {expected}");
    // The power sums themselves against direct summation.
    let w = C64::new(0.9, 0.3);
    for kk in 0..3 {
        let direct: C64 = (0..50)
            .map(|t| w.powu(t as u32) * (t as f64).powi(kk as i32))
            .sum();
        assert!((power_sum(w, 50, kk) - direct).norm() < 1e-12 * direct.norm());
    }
}

/// The frequency-domain errors-in-variables bound with free transients equals the
/// time-domain Fisher information of held records with the initial state and the true
/// force samples as nuisance parameters (derivatives by central differences of an exact
/// simulation). Short records keep the time-domain elimination small.
#[test]
fn bound_matches_brute_force_time_domain_fisher() {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let n = 2;
    let len = 128;
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let refiner = Refiner::default().intersample(Intersample::Zoh);
    let inputs: Vec<DMatrix<f64>> = (0..2)
        .map(|_| DMatrix::from_fn(1, len, |_, _| normal(&mut rng)))
        .collect();
    let levels = NoiseLevels {
        outputs: vec![0.05, 0.08],
        inputs: vec![0.02],
    };
    let truth = SecondOrder::new(m.clone(), k.clone(), r.clone());
    let bound = refiner.cramer_rao(&truth, DT, &inputs, &levels).unwrap();

    let params = Parametrization::Full.parameters(n).unwrap();
    let (theta, _) = param::project(&params, &m, &k, &r);
    let simulate = |theta: &DVector<f64>, u: &DMatrix<f64>, x0: &DVector<f64>| {
        let (mm, kk, rr) = param::matrices(&params, theta, n);
        let model = held_model(&mm, &kk, &rr);
        let (ad, bd) = (model.ad.map(|z| z.re), model.bd.map(|z| z.re));
        let (c, d) = (model.c.map(|z| z.re), model.d.map(|z| z.re));
        let mut x = x0.clone();
        let mut y = DVector::zeros(n * len);
        for t in 0..len {
            let ut = u.column(t);
            let yt = &c * &x + &d * ut;
            for i in 0..n {
                y[t * n + i] = yt[i];
            }
            x = &ad * x + &bd * ut;
        }
        y
    };
    let np = params.len();
    let mut fisher = DMatrix::zeros(np, np);
    let zero = DVector::zeros(2 * n);
    for u in &inputs {
        // Rows: outputs (n len) then the force (len), whitened.
        let rows = (n + 1) * len;
        let white = |row: usize| {
            if row < n * len {
                1.0 / levels.outputs[row % n]
            } else {
                1.0 / levels.inputs[0]
            }
        };
        let mut jt = DMatrix::zeros(rows, np);
        for p in 0..np {
            let h = 1e-6 * theta[p].abs().max(1e-3);
            let mut plus = theta.clone();
            plus[p] += h;
            let mut minus = theta.clone();
            minus[p] -= h;
            let d = (simulate(&plus, u, &zero) - simulate(&minus, u, &zero)) / (2.0 * h);
            for row in 0..n * len {
                jt[(row, p)] = d[row] * white(row);
            }
        }
        // Nuisance: every force sample and the initial state (the response is linear in
        // both).
        let mut z = DMatrix::zeros(rows, len + 2 * n);
        for t in 0..len {
            let mut e = DMatrix::zeros(1, len);
            e[(0, t)] = 1.0;
            let d = simulate(&theta, &e, &zero);
            for row in 0..n * len {
                z[(row, t)] = d[row] * white(row);
            }
            z[(n * len + t, t)] = white(n * len + t);
        }
        for q in 0..2 * n {
            let mut x0 = DVector::zeros(2 * n);
            x0[q] = 1.0;
            let d = simulate(&theta, &DMatrix::zeros(1, len), &x0);
            for row in 0..n * len {
                z[(row, len + q)] = d[row] * white(row);
            }
        }
        let zinv = likelihood::spd_inverse(&z.tr_mul(&z));
        let jz = jt.tr_mul(&z);
        fisher += jt.tr_mul(&jt) - &jz * zinv * jz.transpose();
    }
    let err = (&bound.fisher - &fisher).norm() / fisher.norm();
    let worst_diag = (0..np)
        .map(|p| ((bound.fisher[(p, p)] - fisher[(p, p)]) / fisher[(p, p)]).abs())
        .fold(0.0, f64::max);
    println!("time-domain Fisher: relative difference {err:.2e}, worst diagonal {worst_diag:.2e}");
    // Central differences (step 1e-6 relative, truncation ~1e-12, round-off ~1e-10) and
    // an elimination of 132 nuisance parameters (round-off ~1e-10).
    assert!(err < 1e-6 && worst_diag < 1e-6, "{err:e} {worst_diag:e}");
}

/// The delta method's gradients (frequency, damping ratio, normalized complex shape) against
/// central differences: with the covariance `e_p e_p^T` each reported standard deviation is
/// the magnitude of the derivative with respect to parameter `p`.
#[test]
fn modal_gradients_match_central_differences() {
    for (m, k, r) in [testkit::paper_case1().into_parts(), three_storeys()] {
        let n = m.nrows();
        let params = Parametrization::Full.parameters(n).unwrap();
        let (theta, _) = param::project(&params, &m, &k, &r);
        let mut b2 = DMatrix::zeros(n, 1);
        b2[(0, 0)] = 1.0;
        let build = |theta: &DVector<f64>, derivatives: bool| {
            let (mm, kk, rr) = param::matrices(&params, theta, n);
            Model::new(
                &mm,
                &kk,
                &rr,
                &b2,
                DT,
                Intersample::Zoh,
                derivatives.then_some(params.as_slice()),
            )
            .unwrap()
        };
        let model = build(&theta, true);
        let zero = DMatrix::zeros(params.len(), params.len());
        let values = uncertainty::modal_estimates(&model, &zero).unwrap();
        let mut worst: f64 = 0.0;
        for p in 0..params.len() {
            let mut cov = zero.clone();
            cov[(p, p)] = 1.0;
            let analytic = uncertainty::modal_estimates(&model, &cov).unwrap();
            let h = 1e-6 * theta[p].abs().max(1e-3);
            let mut plus = theta.clone();
            plus[p] += h;
            let mut minus = theta.clone();
            minus[p] -= h;
            let vp = uncertainty::modal_estimates(&build(&plus, true), &zero).unwrap();
            let vm = uncertainty::modal_estimates(&build(&minus, true), &zero).unwrap();
            for j in 0..values.len() {
                let pairs = [
                    (
                        (vp[j].frequency_hz - vm[j].frequency_hz) / (2.0 * h),
                        analytic[j].frequency_std_hz,
                        values[j].frequency_hz,
                    ),
                    (
                        (vp[j].damping_ratio - vm[j].damping_ratio) / (2.0 * h),
                        analytic[j].damping_ratio_std,
                        values[j].damping_ratio,
                    ),
                ];
                for (fd, std, scale) in pairs {
                    // Relative to the quantity per unit relative change of the parameter.
                    let unit = scale / theta[p].abs().max(1e-3);
                    worst = worst.max((fd.abs() - std).abs() / unit);
                }
                for i in 0..n {
                    let d = (vp[j].shape[i] - vm[j].shape[i]) / (2.0 * h);
                    let unit = 1.0 / theta[p].abs().max(1e-3);
                    worst = worst.max((d.re.abs() - analytic[j].shape_std_re[i]).abs() / unit);
                    worst = worst.max((d.im.abs() - analytic[j].shape_std_im[i]).abs() / unit);
                }
            }
        }
        println!("{n} DOF modal gradients: worst error {worst:.1e}");
        // Central differences, step 1e-6 relative to the parameter (truncation ~(h / xi)^2
        // near a lightly damped pole): measured 6e-8 of the derivative's natural unit.
        assert!(worst < 1e-6, "{worst:e}");
    }
}

/// A setting that tests change per thread (`likelihood::CACHE_LIMIT`, ...).
type Setting<V> = std::thread::LocalKey<std::cell::Cell<V>>;

/// Runs `f` on this thread with the likelihood's `setting` at `value` (for example
/// `CACHE_LIMIT` at 0: every group recomputes its model in the Jacobian pass), then restores
/// the previous value. The setting is per thread: `f` must evaluate on this thread (a
/// refinement called from outside rayon's pool moves to a pool thread; see
/// [`on_a_pool_thread`]).
fn with_setting<V: Copy, T>(setting: &'static Setting<V>, value: V, f: impl FnOnce() -> T) -> T {
    let previous = setting.with(|c| c.replace(value));
    let out = f();
    setting.with(|c| c.set(previous));
    out
}

/// Paper case 1's matrices and `hits` records of `len` samples of white-noise force through
/// its exact held model with 2 % noise on every channel (`seed`), and noise levels with a
/// noisy force for evaluating the likelihood on them.
fn case1_records(seed: u64, hits: usize, len: usize) -> (Matrices, Vec<Record>, Noise) {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let records = random_records(&held_model(&m, &k, &r), &mut rng, hits, len, 0.02);
    let noise = Noise {
        outputs: vec![0.02, 0.03],
        inputs: vec![0.01],
    };
    ((m, k, r), records, noise)
}

/// [`case1_records`] with a second group: `hits` records of 512 samples (`seed`) and one of 300
/// (`seed + 1`).
fn two_group_records(seed: u64, hits: usize) -> (Matrices, Vec<Record>, Noise) {
    let (matrices, mut records, noise) = case1_records(seed, hits, 512);
    records.extend(case1_records(seed + 1, 1, 300).1);
    (matrices, records, noise)
}

/// The parameters of paper case 1's mass and stiffness with its damping 1.3 times too large:
/// a point off the estimate to evaluate the likelihood at.
fn off_truth(problem: &Problem, (m, k, r): &Matrices) -> DVector<f64> {
    param::project(&problem.params, m, k, &r.map(|v| v * 1.3)).0
}

/// A start for a refinement near paper case 1: mass 1 % high, stiffness 1 % low, damping
/// 1.5 times too large.
fn near_start((m, k, r): &Matrices) -> SecondOrder {
    SecondOrder::new(m.map(|v| v * 1.01), k.map(|v| v * 0.99), r.map(|v| v * 1.5))
}

/// Every number of an evaluation as text: `Debug` prints each in its shortest round-trip
/// form, so equal text is equal bits.
fn all_bits(ev: &likelihood::Evaluation) -> String {
    format!(
        "{:?} {:?} {:?} {:?} {:?} {:?}",
        ev.cost, ev.xi, ev.fisher, ev.gradient, ev.expected_fisher, ev.residuals
    )
}

/// Runs `f` on a thread of a two-thread pool of its own, returning also how many groups it
/// evaluated there without the full per-bin cache.
fn on_a_pool_thread<T: Send>(f: impl FnOnce() -> T + Send) -> (T, usize) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| {
        let before = likelihood::RECOMPUTED_GROUPS.with(|c| c.get());
        let out = f();
        (
            out,
            likelihood::RECOMPUTED_GROUPS.with(|c| c.get()) - before,
        )
    })
}

/// A group too large for the per-bin cache recomputes the model in the Jacobian pass: the
/// same refinement, bit for bit (held and band-limited, noisy force).
#[test]
fn recomputed_bins_give_the_same_refinement() {
    let (matrices, records, _) = case1_records(7, 2, 512);
    let initial = near_start(&matrices);
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        let refiner = Refiner::default().intersample(intersample);
        let run = |limit: usize| {
            on_a_pool_thread(|| {
                with_setting(&likelihood::CACHE_LIMIT, limit, || {
                    refiner.refine(&records, DT, &initial).unwrap()
                })
            })
        };
        let (cached, none) = run(usize::MAX);
        let (recomputed, groups) = run(0);
        assert!(cached.iterations > 0);
        // The limit took effect: groups were evaluated without the full cache under the
        // zero limit, and none under the unlimited one.
        assert_eq!(none, 0, "{intersample:?}");
        assert!(
            groups > 0,
            "{intersample:?}: the recomputing path did not run"
        );
        // `Debug` prints every number in its shortest round-trip form: equal text is equal
        // bits.
        assert_eq!(
            format!("{cached:?}"),
            format!("{recomputed:?}"),
            "{intersample:?}"
        );
    }
}

/// The refinement keeps the unwhitened residuals of a run's tail evaluation only, and
/// evaluates a run that ended at a point with the Jacobian once more for them: the same
/// refinement, bit for bit, as keeping every point's residuals (a run ending at its iteration
/// limit, and runs ending at their tails; held and band-limited, noisy force).
#[test]
fn residuals_kept_only_where_used_give_the_same_refinement() {
    let (matrices, records, _) = case1_records(19, 3, 512);
    let initial = near_start(&matrices);
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        for iterations in [1, 50] {
            let refiner = Refiner::default()
                .intersample(intersample)
                .max_iterations(iterations);
            let run = |every: bool| {
                on_a_pool_thread(|| {
                    with_setting(&super::EVERY_RESIDUAL, every, || {
                        let before = super::REEVALUATED_ENDS.with(|c| c.get());
                        let out = refiner.refine(&records, DT, &initial).unwrap();
                        (out, super::REEVALUATED_ENDS.with(|c| c.get()) - before)
                    })
                })
                .0
            };
            let ((kept, _), (only_used, again)) = (run(true), run(false));
            assert!(kept.noise_updates > 0, "{intersample:?}");
            // One iteration a run: runs before the last end at their limit, on a point with
            // the Jacobian (unless their one step was a tail step), and are evaluated again.
            if iterations == 1 {
                assert!(again > 0, "{intersample:?}: no run ended on a point");
            }
            println!("{intersample:?}, {iterations} iterations: {again} runs evaluated again");
            assert_eq!(
                format!("{kept:?}"),
                format!("{only_used:?}"),
                "{intersample:?}, {iterations} iterations"
            );
        }
    }
}

/// An evaluation at parameters evaluated before reuses their per-bin model and computes only
/// the weights: the same numbers, bit for bit, as a problem that never saw them (other noise
/// levels, held and band-limited, several groups). Groups that do not keep their model whole
/// keep nothing.
#[test]
fn kept_per_bin_models_give_the_same_evaluation() {
    let (matrices, records, noise) = two_group_records(23, 3);
    let other = Noise {
        outputs: vec![0.05, 0.01],
        inputs: vec![0.02],
    };
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        let refiner = Refiner::default().intersample(intersample);
        let seen = refiner.problem(&records, DT, 2).unwrap();
        assert_eq!(seen.spectra.groups.len(), 2);
        let theta = off_truth(&seen, &matrices);
        seen.evaluate(&theta, &noise, Want::Cost, false).unwrap();
        assert!(seen.memo.lock().unwrap().get(&theta).is_some());
        let reused = || likelihood::REUSED_GROUPS.with(|c| c.get());
        for want in [Want::Cost, Want::JacobianAndFisher] {
            let before = reused();
            let again = seen.evaluate(&theta, &other, want, true).unwrap();
            // Both groups took the kept model; a new problem has none to take.
            assert_eq!(reused() - before, 2, "{intersample:?}, {want:?}");
            let fresh = refiner.problem(&records, DT, 2).unwrap();
            let first = fresh.evaluate(&theta, &other, want, true).unwrap();
            assert_eq!(reused() - before, 2, "{intersample:?}, {want:?}");
            assert_eq!(
                all_bits(&again),
                all_bits(&first),
                "{intersample:?}, {want:?}"
            );
        }
        let whole = refiner.problem(&records, DT, 2).unwrap();
        with_setting(&likelihood::CACHE_LIMIT, 0, || {
            whole.evaluate(&theta, &noise, Want::Cost, false).unwrap()
        });
        assert!(whole.memo.lock().unwrap().entries.is_empty());
    }
}

/// The expected Fisher information from the pass with the weights' derivative (the same
/// rows' sums stopped before its terms) is bit for bit the matrix of a pass without it, in a
/// group of many hits (real transient terms) and of one (complex ones), held and band-limited
/// (the transient in the eigenbasis and in the resolvent form).
#[test]
fn expected_fisher_beside_the_exact_jacobian_is_a_pass_without_it() {
    let (matrices, records, noise) = two_group_records(31, 4);
    for (intersample, eigenbasis) in [
        (Intersample::Zoh, true),
        (Intersample::Bandlimited, true),
        (Intersample::Bandlimited, false),
    ] {
        let problem = Refiner::default()
            .intersample(intersample)
            .problem(&records, DT, 2)
            .unwrap();
        let hits: Vec<usize> = problem
            .spectra
            .groups
            .iter()
            .map(|g| g.hits.len())
            .collect();
        assert_eq!(hits, [1, 4]);
        let theta = off_truth(&problem, &matrices);
        let (both, alone) = with_setting(&likelihood::EIGENBASIS, eigenbasis, || {
            let both = problem
                .evaluate(&theta, &noise, Want::JacobianAndFisher, false)
                .unwrap();
            let without = Want::Jacobian {
                weight_derivative: false,
            };
            (
                both,
                problem.evaluate(&theta, &noise, without, false).unwrap(),
            )
        });
        assert_eq!(
            format!("{:?}", both.expected_fisher),
            format!("{:?}", alone.fisher),
            "{intersample:?}, eigenbasis {eigenbasis}"
        );
        // The two matrices differ (a noisy force): the comparison sees the terms.
        assert_ne!(
            both.expected_fisher, both.fisher,
            "{intersample:?}, eigenbasis {eigenbasis}"
        );
    }
}

/// The likelihood's passes run blocks of bins in parallel and add the blocks' sums in block
/// order: the same numbers, bit for bit, on one thread and on three (several blocks of
/// [`likelihood::BLOCK_BINS`] bins, noisy force, the per-bin cache on and off).
#[test]
fn likelihood_is_the_same_for_any_thread_count() {
    let (matrices, records, noise) = case1_records(11, 3, 1024);
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        let refiner = Refiner::default().intersample(intersample);
        let problem = refiner.problem(&records, DT, 2).unwrap();
        assert!(problem.spectra.groups[0].bins.len() > 3 * likelihood::BLOCK_BINS);
        let theta = off_truth(&problem, &matrices);
        for limit in [usize::MAX, 0] {
            let on = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                // The limit is per thread: set where the evaluation starts.
                all_bits(&pool.install(|| {
                    with_setting(&likelihood::CACHE_LIMIT, limit, || {
                        problem
                            .evaluate(&theta, &noise, Want::JacobianAndFisher, true)
                            .unwrap()
                    })
                }))
            };
            assert_eq!(on(1), on(3), "{intersample:?}, cache limit {limit}");
        }
    }
}

/// With few hits in a group the Jacobian pass puts the transient terms into each hit's rows
/// as complex terms with the coefficients `R z xi`: the same Jacobian as the per-bin form,
/// summed in another order. Pass 1 is not touched (cost, transients and residuals bit for
/// bit); the matrices agree to rounding (held and band-limited, noisy force, the per-bin cache
/// on and off). The resolvent form of the transient: the eigenbasis has no per-hit form.
#[test]
fn few_hit_transient_terms_match_the_per_bin_form() {
    let (matrices, records, noise) = case1_records(13, 3, 512);
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        let refiner = Refiner::default().intersample(intersample);
        let problem = refiner.problem(&records, DT, 2).unwrap();
        let theta = off_truth(&problem, &matrices);
        for cache in [usize::MAX, 0] {
            let run = |few: usize| {
                with_setting(&likelihood::CACHE_LIMIT, cache, || {
                    with_setting(&likelihood::FEW_HITS_LIMIT, few, || {
                        with_setting(&likelihood::EIGENBASIS, false, || {
                            problem
                                .evaluate(&theta, &noise, Want::JacobianAndFisher, true)
                                .unwrap()
                        })
                    })
                })
            };
            let (per_bin, per_hit) = (run(0), run(3));
            assert_eq!(
                format!(
                    "{:?} {:?} {:?}",
                    per_bin.cost, per_bin.xi, per_bin.residuals
                ),
                format!(
                    "{:?} {:?} {:?}",
                    per_hit.cost, per_hit.xi, per_hit.residuals
                ),
            );
            let relative = |a: &Option<DMatrix<f64>>, b: &Option<DMatrix<f64>>| {
                let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
                (a - b).norm() / a.norm()
            };
            let fisher = relative(&per_bin.fisher, &per_hit.fisher);
            let expected = relative(&per_bin.expected_fisher, &per_hit.expected_fisher);
            // The gradient on its own scale per parameter, sqrt(F_pp cost) (the gradient
            // cosine's denominator): at the projected solution it is a sum of cancelling terms.
            let f = per_bin.fisher.as_ref().unwrap();
            let (g0, g1) = (
                per_bin.gradient.as_ref().unwrap(),
                per_hit.gradient.as_ref().unwrap(),
            );
            let gradient = (0..g0.len())
                .map(|p| (g0[p] - g1[p]).abs() / (f[(p, p)] * per_bin.cost).sqrt())
                .fold(0.0, f64::max);
            println!(
                "{intersample:?}, cache limit {cache}: Fisher {fisher:.1e}, expected {expected:.1e}, gradient {gradient:.1e}"
            );
            // Rounding only: measured up to 1.4e-16 (matrices) and 2.4e-17 (gradient), and
            // 1e-12 leaves room for other platforms' rounding. A wrong term is far larger (the
            // coefficients with `R z` transposed: 2.4e6 and 87).
            assert!(
                fisher < 1e-12 && expected < 1e-12,
                "{fisher:e} {expected:e}"
            );
            assert!(gradient < 1e-12, "{gradient:e}");
        }
    }
}

/// The transient in the model's eigenbasis (band-limited, lightly damped) gives the evaluation
/// of the resolvent form to rounding: the projected cost, its gradient, the Gauss-Newton
/// matrix with and without the weights' derivative, the expected Fisher information beside
/// the former, the transients (in the state's coordinates) and the residuals. Two storeys
/// (a group of one hit and one of four) and three (non-proportional damping), noisy force, the
/// per-bin cache on and off. The resolvent form runs second on the same problem, whose kept
/// per-bin models (the eigenbasis') it must not take.
#[test]
fn eigenbasis_transient_matches_the_resolvent_form() {
    let (case1, records1, noise1) = two_group_records(41, 4);
    let three = three_storeys();
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let records3 = random_records(
        &held_model(&three.0, &three.1, &three.2),
        &mut rng,
        3,
        512,
        0.02,
    );
    let noise3 = Noise {
        outputs: vec![0.02, 0.03, 0.025],
        inputs: vec![0.01],
    };
    for (matrices, records, noise) in [(case1, records1, noise1), (three, records3, noise3)] {
        let n = matrices.0.nrows();
        let problem = Refiner::default()
            .intersample(Intersample::Bandlimited)
            .problem(&records, DT, n)
            .unwrap();
        let theta = off_truth(&problem, &matrices);
        for cache in [usize::MAX, 0] {
            let run = |eigenbasis: bool| {
                with_setting(&likelihood::CACHE_LIMIT, cache, || {
                    with_setting(&likelihood::EIGENBASIS, eigenbasis, || {
                        let before = likelihood::EIGENBASIS_EVALUATIONS.with(|c| c.get());
                        let both = problem
                            .evaluate(&theta, &noise, Want::JacobianAndFisher, true)
                            .unwrap();
                        let without = Want::Jacobian {
                            weight_derivative: false,
                        };
                        let alone = problem.evaluate(&theta, &noise, without, false).unwrap();
                        let used = likelihood::EIGENBASIS_EVALUATIONS.with(|c| c.get()) - before;
                        assert_eq!(used, if eigenbasis { 2 } else { 0 });
                        (both, alone)
                    })
                })
            };
            let ((eig, eig_alone), (res, res_alone)) = (run(true), run(false));
            let relative = |a: &DMatrix<f64>, b: &DMatrix<f64>| (a - b).norm() / b.norm();
            let cost = (eig.cost - res.cost).abs() / res.cost;
            let fisher = relative(eig.fisher.as_ref().unwrap(), res.fisher.as_ref().unwrap());
            let expected = relative(
                eig.expected_fisher.as_ref().unwrap(),
                res.expected_fisher.as_ref().unwrap(),
            );
            let alone = relative(
                eig_alone.fisher.as_ref().unwrap(),
                res_alone.fisher.as_ref().unwrap(),
            );
            // The gradient on its own scale per parameter, sqrt(F_pp cost) (the gradient
            // cosine's denominator): at the projected solution it is a sum of cancelling terms.
            let f = res.fisher.as_ref().unwrap();
            let (g0, g1) = (
                res.gradient.as_ref().unwrap(),
                eig.gradient.as_ref().unwrap(),
            );
            let gradient = (0..g0.len())
                .map(|p| (g0[p] - g1[p]).abs() / (f[(p, p)] * res.cost).sqrt())
                .fold(0.0, f64::max);
            let xi = eig
                .xi
                .iter()
                .zip(&res.xi)
                .map(|(a, b)| (a - b).norm() / b.norm())
                .fold(0.0, f64::max);
            let residuals = eig
                .residuals
                .as_ref()
                .unwrap()
                .iter()
                .zip(res.residuals.as_ref().unwrap())
                .map(|(a, b)| (a - b).norm() / b.norm())
                .fold(0.0, f64::max);
            println!(
                "{n} DOF, cache limit {cache}: cost {cost:.1e}, Fisher {fisher:.1e}, expected {expected:.1e}, without the weight derivative {alone:.1e}, gradient {gradient:.1e}, transients {xi:.1e}, residuals {residuals:.1e}"
            );
            // Rounding only, of two computations of the same quantities (eigenvectors and
            // exponentials of eigenvalues against the resolvent of expm(A dt) and Frechet
            // derivatives; near the resonances both lose what z I - A_d's conditioning costs):
            // measured cost 2.1e-15, matrices up to 3.1e-14, gradient 1.0e-14, transients
            // 1.4e-14, residuals 1.4e-13; 1e-9 leaves room for other models and platforms. A
            // wrong or missing term is far larger (without the eigenvectors' derivative
            // `C dv`: 1.3e-2 in the matrices, 1.6e-2 in the gradient).
            assert!(cost < 1e-9, "cost {cost:e}");
            assert!(
                fisher < 1e-9 && expected < 1e-9 && alone < 1e-9,
                "{fisher:e} {expected:e} {alone:e}"
            );
            assert!(gradient < 1e-9, "gradient {gradient:e}");
            assert!(xi < 1e-9 && residuals < 1e-9, "{xi:e} {residuals:e}");
        }
    }
}

/// The eigenbasis form is not taken where the decomposition is not safe, and those models'
/// evaluations are the resolvent form's bit for bit: held inputs, an overdamped mode (real
/// eigenvalues), two equal uncoupled oscillators (repeated eigenvalues).
#[test]
fn eigenbasis_falls_back_to_the_resolvent_form() {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let b2 = DMatrix::from_column_slice(2, 1, &[1.0, 0.0]);
    let build = |m: &DMatrix<f64>, k: &DMatrix<f64>, r: &DMatrix<f64>, intersample| {
        Model::new(m, k, r, &b2, DT, intersample, None).unwrap()
    };
    // 200 times paper case 1's damping: damping ratios 1.08 (overdamped) and 0.50.
    let heavy = &r * 200.0;
    let overdamped = build(&m, &k, &heavy, Intersample::Bandlimited);
    let real = linalg::eig(&overdamped.a)
        .unwrap()
        .values
        .iter()
        .filter(|l| l.im.abs() < 1e-6 * l.norm())
        .count();
    assert_eq!(real, 2, "one overdamped mode");
    assert!(eigenbasis::Eigenbasis::new(&build(&m, &k, &r, Intersample::Bandlimited)).is_some());
    assert!(eigenbasis::Eigenbasis::new(&build(&m, &k, &r, Intersample::Zoh)).is_none());
    assert!(eigenbasis::Eigenbasis::new(&overdamped).is_none());
    let eye = DMatrix::identity(2, 2);
    let twins = build(
        &eye,
        &(&eye * 400.0),
        &(&eye * 0.2),
        Intersample::Bandlimited,
    );
    assert!(eigenbasis::Eigenbasis::new(&twins).is_none());
    // The evaluations: no eigenbasis, the same bits with the form allowed or not.
    let (matrices, records, noise) = case1_records(43, 3, 512);
    for (intersample, damping) in [
        (Intersample::Zoh, matrices.2.clone()),
        (Intersample::Bandlimited, heavy),
    ] {
        let problem = Refiner::default()
            .intersample(intersample)
            .problem(&records, DT, 2)
            .unwrap();
        let theta = param::project(&problem.params, &matrices.0, &matrices.1, &damping).0;
        let run = |eigenbasis: bool| {
            with_setting(&likelihood::EIGENBASIS, eigenbasis, || {
                let before = likelihood::EIGENBASIS_EVALUATIONS.with(|c| c.get());
                let ev = problem
                    .evaluate(&theta, &noise, Want::JacobianAndFisher, true)
                    .unwrap();
                let used = likelihood::EIGENBASIS_EVALUATIONS.with(|c| c.get()) - before;
                (all_bits(&ev), used)
            })
        };
        let (allowed, used) = run(true);
        assert_eq!(used, 0, "{intersample:?}");
        assert_eq!(allowed, run(false).0, "{intersample:?}");
    }
}

/// A group of fewer hits than threads splits each hit's projection across the threads: the
/// same arithmetic per value, so the same numbers bit for bit (one hit, held and band-limited,
/// noisy force).
#[test]
fn split_projection_gives_the_same_numbers() {
    let (matrices, records, noise) = case1_records(17, 1, 2048);
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        let refiner = Refiner::default().intersample(intersample);
        let problem = refiner.problem(&records, DT, 2).unwrap();
        let theta = off_truth(&problem, &matrices);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        // The threshold and the counter are per thread: set and read where the evaluation
        // starts. Parts of 20 rows: several, the last one shorter.
        let run = |rows: usize| {
            pool.install(|| {
                let before = likelihood::SPLIT_GROUPS.with(|c| c.get());
                let ev = with_setting(&likelihood::SPLIT_ROWS, rows, || {
                    problem
                        .evaluate(&theta, &noise, Want::JacobianAndFisher, true)
                        .unwrap()
                });
                let split = likelihood::SPLIT_GROUPS.with(|c| c.get()) - before;
                (all_bits(&ev), split)
            })
        };
        let (whole, none) = run(usize::MAX);
        let (parts, split) = run(20);
        assert_eq!(
            (none, split),
            (0, 1),
            "{intersample:?}: the split did not run"
        );
        assert_eq!(whole, parts, "{intersample:?}");
    }
}

/// The noise fit sums its normal equations over parts of the cells in parallel, the parts'
/// sums added in order: the same levels for any thread count, bit for bit, and those of the
/// sum in one pass to rounding (outputs and force estimated, parts of 7 cells).
#[test]
fn noise_fit_in_parts_matches_the_sum_in_one_pass() {
    let ((m, k, r), records, noise) = case1_records(19, 3, 1024);
    let problem = Refiner::default()
        .intersample(Intersample::Bandlimited)
        .problem(&records, DT, 2)
        .unwrap();
    let (theta, _) = param::project(&problem.params, &m, &k, &r);
    let ev = problem.evaluate(&theta, &noise, Want::Cost, true).unwrap();
    let fit = likelihood::NoiseFit {
        m: 2,
        r: 1,
        estimate_inputs: true,
        dof_factor: 1.0,
        output_rms: vec![1.0; 2],
        input_rms: vec![1.0],
    };
    let at = |cells: usize, threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            with_setting(&likelihood::NOISE_PART_LIMIT, cells, || {
                likelihood::estimate_noise(&problem.spectra, &ev, &fit)
            })
        })
    };
    let whole = at(usize::MAX, 1);
    let (one, three) = (at(7, 1), at(7, 3));
    assert_eq!(one, three);
    assert!(whole.inputs[0] > 0.0, "the force noise was fitted");
    let levels = |n: &Noise| [n.outputs.clone(), n.inputs.clone()].concat();
    let worst = levels(&whole)
        .iter()
        .zip(levels(&one))
        .map(|(a, b)| ((a - b) / a).abs())
        .fold(0.0, f64::max);
    println!("noise levels in parts against one pass: {worst:.1e}");
    // Rounding: measured 2.4e-15 relative (IRLS iterates on the sums), and 1e-12 leaves room
    // for other platforms. A part lost moves the levels by far more (dropping the last one
    // fails this test: mutation tried).
    assert!(worst < 1e-12, "{worst:e}");
}

/// A toy least-squares problem for the optimizer, whitened by its noise level (0.01): a cost
/// near the number of points. `curved`: `y_i = a exp(-b t_i)`; otherwise the straight line
/// `y_i = a + b t_i` (a quadratic cost, whose quadratic model is exact).
fn toy_fit(curved: bool) -> impl Fn(&DVector<f64>) -> Option<lm::Point<()>> {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.05).collect();
    let model = move |a: f64, b: f64, t: f64| {
        if curved {
            let e = (-b * t).exp();
            (a * e, [e, -a * t * e])
        } else {
            (a + b * t, [1.0, t])
        }
    };
    let y: Vec<f64> = t
        .iter()
        .map(|&t| model(2.0, 0.7, t).0 + 0.01 * normal(&mut rng))
        .collect();
    move |theta: &DVector<f64>| {
        let mut j = DMatrix::zeros(t.len(), 2);
        let r = DVector::from_fn(t.len(), |i, _| {
            let (value, d) = model(theta[0], theta[1], t[i]);
            j[(i, 0)] = -d[0] / 0.01;
            j[(i, 1)] = -d[1] / 0.01;
            (y[i] - value) / 0.01
        });
        Some(lm::Point {
            cost: r.norm_squared(),
            fisher: j.transpose() * &j,
            gradient: j.transpose() * &r,
            extra: (),
        })
    }
}

/// The tail step ends a run at the point `minimize` ends at (the same steps up to it), with
/// one full evaluation fewer when the quadratic model is accurate; when it is not, the
/// point is evaluated in full and the run goes on as `minimize` does. With both damping
/// floors: the FRF refinement's and the refinement from records'.
#[test]
fn tail_step_ends_where_the_full_run_goes() {
    for (damping_floor, curved, start) in [lm::NIELSEN_FLOOR, lm::DAMPING_DECREASE_FLOOR]
        .into_iter()
        .flat_map(|floor| {
            [
                (floor, false, [1.0, 2.0]),
                (floor, true, [1.0, 2.0]),
                (floor, true, [10.0, 0.05]),
            ]
        })
    {
        let settings = lm::Settings {
            max_iterations: 100,
            gradient_tolerance: 0.0,
            step_tolerance: 0.0,
            cost_tolerance: 0.0,
            decrease_tolerance: 1e-5,
            damping_floor,
        };
        let fit = toy_fit(curved);
        let theta0 = DVector::from_row_slice(&start);
        let seen = std::cell::RefCell::new(Vec::new());
        let full = lm::minimize(
            theta0.clone(),
            fit(&theta0).unwrap(),
            settings,
            lm::INITIAL_DAMPING,
            |t, _| {
                seen.borrow_mut().push(t.clone());
                fit(t)
            },
        );
        let seen = seen.into_inner();
        assert_eq!(full.stop, StopReason::Cost);
        let (full_evals, tail_evals) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
        let tail = lm::minimize_to_tail(
            theta0.clone(),
            fit(&theta0).unwrap(),
            settings,
            lm::INITIAL_DAMPING,
            |t, _| {
                full_evals.set(full_evals.get() + 1);
                fit(t)
            },
            |t| {
                tail_evals.set(tail_evals.get() + 1);
                fit(t).map(|p| (p.cost, ()))
            },
        );
        assert_eq!(tail.stop, StopReason::Cost);
        // Bit for bit the point the full run ended at.
        assert_eq!(tail.theta, full.theta, "{curved} {start:?}");
        match tail.end {
            lm::End::Tail(_) => assert_eq!(full_evals.get() + 1, seen.len()),
            lm::End::Point(_) => assert_eq!(full_evals.get(), seen.len()),
        }
        if !curved {
            assert!(matches!(tail.end, lm::End::Tail(_)));
            assert_eq!(tail_evals.get(), 1);
        }
    }
}

/// The refinement's last point, reached by a step evaluated for the expected Fisher
/// information only, is within [`STATISTICAL_TOLERANCE`]: a full Gauss-Newton step from it
/// would lower the cost by at most that (checked with the Jacobian there), and its Fisher
/// matrix and cost are those of a fresh evaluation at the estimate, bit for bit.
#[test]
fn last_point_is_within_the_statistical_tolerance() {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let data_model = held_model(&m, &k, &r);
    let records = random_records(&data_model, &mut rng, 4, 1024, 0.01);
    let initial = SecondOrder::new(m.map(|v| v * 1.02), k.map(|v| v * 0.98), r.map(|v| v * 3.0));
    for (intersample, noise_model) in [
        (Intersample::Zoh, NoiseModel::Estimate),
        (Intersample::Zoh, NoiseModel::EstimateOutputsOnly),
        (Intersample::Bandlimited, NoiseModel::Estimate),
    ] {
        let refiner = Refiner::default()
            .intersample(intersample)
            .noise(noise_model.clone());
        let refined = refiner.refine(&records, DT, &initial).unwrap();
        assert!(refined.stop.converged(), "{intersample:?} {noise_model:?}");
        let problem = refiner.problem(&records, DT, 2).unwrap();
        let noise = Noise {
            outputs: refined.noise.outputs.clone(),
            inputs: refined.noise.inputs.clone(),
        };
        let ev = problem
            .evaluate(
                &refined.parameters,
                &noise,
                Want::Jacobian {
                    weight_derivative: true,
                },
                false,
            )
            .unwrap();
        let (fisher, gradient) = (ev.fisher.unwrap(), ev.gradient.unwrap());
        let decrease = gradient.dot(&fisher.clone().cholesky().unwrap().solve(&gradient));
        // The step's quadratic model predicted at most the tolerance; the decrease left was
        // 0.991 to 1.041 times the model's on 25 paper-case-1 campaigns: a factor 2 margin.
        assert!(
            decrease <= 2.0 * STATISTICAL_TOLERANCE,
            "{intersample:?} {noise_model:?}: {decrease:e} left"
        );
        let model = problem.model(&refined.parameters, true).unwrap();
        assert_eq!(
            refined.uncertainty.fisher,
            problem.expected_fisher(&model, &noise).unwrap(),
            "{intersample:?} {noise_model:?}"
        );
        assert_eq!(refined.cost, ev.cost, "{intersample:?} {noise_model:?}");
    }
}

/// The first run on every other bin ([`FIRST_RUN_BIN_STRIDE`]): the subset keeps those bins
/// and their DFT values, and a refinement from a poor start (M and K 2 % off, damping x3)
/// converges to the optimum of one whose first run is on every bin (held and band-limited).
#[test]
fn first_run_on_every_other_bin_reaches_the_same_optimum() {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let initial = SecondOrder::new(m.map(|v| v * 1.02), k.map(|v| v * 0.98), r.map(|v| v * 3.0));
    for intersample in [Intersample::Zoh, Intersample::Bandlimited] {
        // Records of the model refined (held or band-limited). Held records under the
        // band-limited model (as before) are a misfit whose refinement takes 200 to 300
        // iterations and ends where rounding takes it: changes of the start's stiffness by
        // 1e-13 to 2e-12 relative moved the ends of the runs with the first on every other bin
        // by up to 0.66 standard deviations (12 starts), those on every bin by under 0.01; with
        // the transient in the eigenbasis up to 2.3.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let b2 = DMatrix::from_column_slice(2, 1, &[1.0, 0.0]);
        let truth = Model::new(&m, &k, &r, &b2, DT, intersample, None).unwrap();
        let records = random_records(&truth, &mut rng, 4, 1024, 0.01);
        let refiner = Refiner::default().intersample(intersample);
        let problem = refiner.problem(&records, DT, 2).unwrap();
        let coarse = problem.subset(2).unwrap();
        let (all_bins, some) = (&problem.spectra.groups[0], &coarse.spectra.groups[0]);
        let every_other: Vec<_> = all_bins.bins.iter().step_by(2).copied().collect();
        assert_eq!(some.bins, every_other, "{intersample:?}");
        assert_eq!(some.hits, all_bins.hits, "{intersample:?}");
        for h in 0..records.len() {
            for j in 0..some.bins.len() {
                assert_eq!(
                    coarse.spectra.y[h].column(j),
                    problem.spectra.y[h].column(2 * j)
                );
                assert_eq!(
                    coarse.spectra.u[h].column(j),
                    problem.spectra.u[h].column(2 * j)
                );
            }
        }
        let run = |stride: usize| {
            on_a_pool_thread(|| {
                with_setting(&super::FIRST_RUN_STRIDE, stride, || {
                    refiner.refine(&records, DT, &initial).unwrap()
                })
            })
            .0
        };
        let (all, coarse_first) = (run(1), run(2));
        assert!(all.stop.converged(), "{intersample:?}");
        assert!(coarse_first.stop.converged(), "{intersample:?}");
        let moved = all
            .parameters
            .iter()
            .zip(coarse_first.parameters.iter())
            .zip(all.uncertainty.parameter_std.iter())
            .map(|((a, b), sd)| (a - b).abs() / sd)
            .fold(0.0, f64::max);
        let levels = |r: &Refinement| {
            r.noise
                .outputs
                .iter()
                .chain(&r.noise.inputs)
                .copied()
                .collect::<Vec<_>>()
        };
        let noise_moved = levels(&all)
            .iter()
            .zip(levels(&coarse_first))
            .map(|(a, b)| (a - b).abs() / a)
            .fold(0.0, f64::max);
        println!("{intersample:?}: parameters moved {moved:.2e} std, noise {noise_moved:.2e}");
        // Measured: 3.0e-4 and 2.3e-4 standard deviations, noise levels 9.2e-4 and 7.3e-4
        // (held, band-limited); the alternation of noise fit and refinement stops about 2e-3
        // from its fixed point (see `NOISE_CHANGE_TOLERANCE`).
        assert!(
            moved < 2e-2,
            "{intersample:?}: {moved:e} standard deviations"
        );
        assert!(
            noise_moved < 3e-3,
            "{intersample:?}: noise levels {noise_moved:e}"
        );
    }
}

/// The noise alternation reports how much its last re-estimation moved the levels. On held
/// records with the held model: stopped after one update (from the robust start's weights the
/// levels move by about their own size) it has not settled, with the default four it has, and
/// given levels never move. The band-limited model of the same held records (misspecified)
/// never settles: its levels still moved by about 9.5 at the fourth update, which was silent
/// before this was reported.
#[test]
fn an_unsettled_noise_alternation_is_reported() {
    let (matrices, records, _) = case1_records(23, 3, 512);
    let initial = near_start(&matrices);
    let refine =
        |refiner: Refiner| on_a_pool_thread(|| refiner.refine(&records, DT, &initial).unwrap()).0;
    let held = Refiner::default().intersample(Intersample::Zoh);
    let once = refine(Refiner {
        max_noise_updates: 1,
        ..held.clone()
    });
    assert_eq!(once.noise_updates, 1);
    assert!(
        once.noise_change >= super::NOISE_CHANGE_TOLERANCE && !once.noise_settled(),
        "one update: change {}",
        once.noise_change
    );
    let settled = refine(held.clone());
    assert!(
        settled.noise_settled() && settled.noise_change > 0.0,
        "{} updates: change {}",
        settled.noise_updates,
        settled.noise_change
    );
    let given = refine(held.noise(NoiseModel::Known(settled.noise.clone())));
    assert_eq!((given.noise_updates, given.noise_change), (0, 0.0));
    assert!(given.noise_settled());
    let misspecified = refine(Refiner::default().intersample(Intersample::Bandlimited));
    assert_eq!(misspecified.noise_updates, 4);
    assert!(
        !misspecified.noise_settled(),
        "change {}",
        misspecified.noise_change
    );
}
