use super::*;
use crate::modal::{Intersample, ModalParams};
use crate::statespace::StateSpace;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};

fn three_dof() -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    testkit::ShearFrame::lumped(&[1.0, 0.9, 0.8], &[1000.0, 900.0, 800.0])
        .rayleigh(0.12, 1.5e-4)
        .into_parts()
}

/// Modes of the exact ZOH discretization of a frame (force at DOF 0).
fn exact_modes(m: &DMatrix<f64>, k: &DMatrix<f64>, r: &DMatrix<f64>) -> (Vec<Mode>, DMatrix<f64>) {
    let (ac, bc, c, d) = testkit::ShearFrame::new(m.clone(), k.clone(), r.clone()).continuous(0);
    let dt = 1.0 / 64.0;
    let (ad, bd) = testkit::zoh(&ac, &bc, dt);
    let ss = StateSpace::new(ad, bd, c, d.clone(), dt);
    let model = ModalParams::new(Intersample::Zoh).fit(&ss, None).unwrap();
    (model.modes, d)
}

#[test]
fn exact_modes_give_back_mass_stiffness_and_damping() {
    for (m, k, r) in [testkit::paper_case1().into_parts(), three_dof()] {
        let (modes, d) = exact_modes(&m, &k, &r);
        let mkr = MkrParams::default().fit(&modes, &d).unwrap();
        // Exact modal data: expm, eig and two small inversions, round-off only (~1e-12).
        assert!(
            linalg::relative_error(&mkr.mass, &m) < 1e-9,
            "M {}",
            mkr.mass
        );
        assert!(
            linalg::relative_error(&mkr.stiffness, &k) < 1e-9,
            "K {}",
            mkr.stiffness
        );
        assert!(
            linalg::relative_error(&mkr.damping, &r) < 1e-7,
            "R {}",
            mkr.damping
        );
        assert!(mkr.consistency < 1e-9, "consistency {}", mkr.consistency);
        assert!(!mkr.polarity_flipped);
        assert!(mkr.driving_point > 0.0);
        assert!(mkr.w_squared.iter().all(|z| z.im < 0.0));
    }
}

#[test]
fn inverted_polarity_is_flipped_or_refused() {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let (mut modes, d) = exact_modes(&m, &k, &r);
    for md in &mut modes {
        md.residue.neg_mut();
    }
    let flipped = MkrParams::default().fit(&modes, &-&d).unwrap();
    assert!(flipped.polarity_flipped);
    assert!(linalg::relative_error(&flipped.mass, &m) < 1e-9);
    assert!(flipped.driving_point > 0.0);
    let refuse = MkrParams {
        polarity: PolarityPolicy::Refuse,
        ..MkrParams::default()
    };
    assert!(matches!(
        refuse.fit(&modes, &-&d),
        Err(MkrError::PolarityInverted { driving_point }) if driving_point < 0.0
    ));
    // One mode inverted only: mixed signs.
    modes[0].residue.neg_mut();
    assert!(matches!(
        MkrParams::default().fit(&modes, &d),
        Err(MkrError::InconsistentPolarity { .. })
    ));
}

#[test]
fn errors_are_typed() {
    let (m, k, r) = testkit::paper_case1().into_parts();
    let (modes, d) = exact_modes(&m, &k, &r);
    assert_eq!(
        MkrParams::default().fit(&modes[..1], &d),
        Err(MkrError::ModeCountMismatch { modes: 1, dofs: 2 })
    );
    let out_of_range = MkrParams {
        collocated: CollocatedPair {
            output: 2,
            input: 0,
        },
        ..MkrParams::default()
    };
    assert!(matches!(
        out_of_range.fit(&modes, &d),
        Err(MkrError::CollocatedOutOfRange {
            output: 2,
            outputs: 2,
            ..
        })
    ));
    // A non-collocated shape entry turned by 90 degrees (and scaled) makes the data
    // non-physical: that mode's contribution to M^-1 = W Lc W^T changes sign at DOF 1 and
    // the mass matrix comes out indefinite.
    let mut bad = modes.clone();
    bad[0].residue[(1, 0)] *= C64::new(0.0, 3.0);
    match MkrParams::default().fit(&bad, &d) {
        Err(MkrError::NotPositiveDefinite {
            matrix,
            pivot,
            value,
        }) => {
            assert_eq!((matrix, pivot), (MatrixKind::Mass, 1));
            assert!(value <= 0.0);
        }
        other => panic!("expected NotPositiveDefinite, got {other:?}"),
    }
}

/// A structural mode of continuous pole `pole` (frequency `|pole| / 2 pi`), with perfect
/// indicators: what the oracles below hand to MKR.
fn oracle_mode(
    pole: C64,
    damping_ratio: f64,
    shape: nalgebra::DVector<C64>,
    residue: DMatrix<C64>,
) -> Mode {
    Mode {
        frequency_hz: pole.norm() / (2.0 * std::f64::consts::PI),
        damping_ratio,
        eigenvalue: pole,
        pole,
        shape,
        residue,
        indicators: crate::modal::Indicators {
            emac_output: None,
            emac_input: None,
            mpc: 1.0,
            msv: 1.0,
            msv_relative: 1.0,
            cmi: 1.0,
        },
        structural: true,
    }
}

/// Exact continuous modes of `M q'' + R q' + K q = f`, accelerations at every DOF, forces
/// at `input_dofs`, without the crate's eigensolver: poles from nalgebra's eigenvalues of
/// the state matrix, the shape `phi` as the null vector of `lambda^2 M + lambda R + K`
/// (nalgebra's complex SVD), and the closed-form accelerance residue of a symmetric
/// quadratic pencil, `lambda^2 phi phi^T / (phi^T (2 lambda M + R) phi)`.
fn oracle_modes(
    m: &DMatrix<f64>,
    k: &DMatrix<f64>,
    r: &DMatrix<f64>,
    input_dofs: &[usize],
) -> (Vec<Mode>, DMatrix<f64>) {
    let n = m.nrows();
    let mi = m.clone().try_inverse().unwrap();
    let (a, _, _, _) = testkit::ShearFrame::new(m.clone(), k.clone(), r.clone()).continuous(0);
    let to_c = |x: &DMatrix<f64>| x.map(|v| C64::new(v, 0.0));
    let modes = a
        .complex_eigenvalues()
        .iter()
        .filter(|l| l.im > 0.0)
        .map(|&lambda| {
            let q = to_c(m) * (lambda * lambda) + to_c(r) * lambda + to_c(k);
            let svd = q.svd(false, true);
            let v_t = svd.v_t.unwrap();
            let imin = (0..n)
                .min_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]))
                .unwrap();
            let phi: nalgebra::DVector<C64> = v_t.row(imin).adjoint();
            let norm = (phi.transpose() * (to_c(m) * (lambda * 2.0) + to_c(r)) * &phi)[(0, 0)];
            let residue = DMatrix::from_fn(n, input_dofs.len(), |i, j| {
                lambda * lambda * phi[i] * phi[input_dofs[j]] / norm
            });
            oracle_mode(lambda, -lambda.re / lambda.norm(), phi, residue)
        })
        .collect();
    let d = DMatrix::from_fn(n, input_dofs.len(), |i, j| mi[(i, input_dofs[j])]);
    (modes, d)
}

/// Relative errors of M, K and damping against the truth.
fn mkr_errors(fit: &Mkr, m: &DMatrix<f64>, k: &DMatrix<f64>, r: &DMatrix<f64>) -> [f64; 3] {
    [
        linalg::relative_error(&fit.mass, m),
        linalg::relative_error(&fit.stiffness, k),
        linalg::relative_error(&fit.damping, r),
    ]
}

#[test]
fn oracle_modes_give_back_frames_from_every_driving_point_and_either_polarity() {
    let mut rng = ChaCha8Rng::seed_from_u64(1201);
    let mut uniform = |lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
    let mut worst = [0.0f64; 3];
    let mut against = 0;
    for case in 0..24 {
        let n = 2 + case % 2;
        let masses: Vec<f64> = (0..n).map(|_| uniform(0.5, 2.0)).collect();
        let springs: Vec<f64> = (0..n).map(|_| uniform(300.0, 3000.0)).collect();
        // Storey dashpots of unrelated sizes: non-proportional damping (complex modes).
        let dashpots: Vec<f64> = (0..n).map(|_| uniform(0.05, 3.0)).collect();
        let (m, k, _) = testkit::ShearFrame::lumped(&masses, &springs).into_parts();
        let r = testkit::chain_matrix(&dashpots);
        for drive in 0..n {
            // The force at `drive`, alone or as the second input after a force elsewhere.
            let other = (drive + 1) % n;
            for (inputs, l) in [(vec![drive], 0), (vec![other, drive], 1)] {
                let (modes, d) = oracle_modes(&m, &k, &r, &inputs);
                let params = MkrParams {
                    collocated: CollocatedPair {
                        output: drive,
                        input: l,
                    },
                    ..MkrParams::default()
                };
                let fit = params.fit(&modes, &d).unwrap();
                assert!(!fit.polarity_flipped);
                // Near a node of the driving point a complex mode's W^2 can have any phase
                // (case 11, drive 1: 2.8e-7 + 6.1e-8 i next to -0.013 i); such modes do not
                // vote on the polarity.
                against += fit.w_squared.iter().filter(|z| z.im >= 0.0).count();
                let mi = m.clone().try_inverse().unwrap();
                assert!((fit.driving_point - mi[(drive, drive)]).abs() < 1e-15);
                let errors = mkr_errors(&fit, &m, &k, &r);
                // Exact modes; the consistency W W^T is round-off of the residues.
                assert!(fit.consistency < 1e-12, "consistency {:e}", fit.consistency);
                // Inverted wiring: every residue and D negated.
                let mut inverted = modes.clone();
                for md in &mut inverted {
                    md.residue.neg_mut();
                }
                let flipped = params.fit(&inverted, &-&d).unwrap();
                assert!(flipped.polarity_flipped);
                assert!((flipped.driving_point - mi[(drive, drive)]).abs() < 1e-15);
                let flipped_errors = mkr_errors(&flipped, &m, &k, &r);
                let refuse = MkrParams {
                    polarity: PolarityPolicy::Refuse,
                    ..params
                };
                assert!(matches!(
                    refuse.fit(&inverted, &-&d),
                    Err(MkrError::PolarityInverted { driving_point }) if driving_point < 0.0
                ));
                for i in 0..3 {
                    worst[i] = worst[i].max(errors[i]).max(flipped_errors[i]);
                }
            }
        }
    }
    // Round-off of an SVD null vector and two 3 x 3 inversions of products whose terms
    // cancel to the frame's scale; measured M, K, damping.
    eprintln!("worst M, K, damping errors {worst:?}, {against} modes against");
    assert!(against > 0, "no near-nodal mode voted against the polarity");
    assert!(worst[0] < 1e-11, "M {:e}", worst[0]);
    assert!(worst[1] < 1e-11, "K {:e}", worst[1]);
    assert!(worst[2] < 1e-9, "damping {:e}", worst[2]);
}

#[test]
fn repeated_and_close_frequencies_give_back_classically_damped_systems() {
    // M^(1/2) Q diag(.) Q^T M^(1/2) with a rotation Q: modes phi_j = M^(-1/2) q_j share no
    // node with either DOF, and the closed-form accelerance residue of a classically damped
    // mode is lambda^2 phi phi^T / (2 i omega_d). delta = 0 is an exactly repeated pole
    // (nalgebra's null vector would be arbitrary there, hence the closed form).
    let mut rng = ChaCha8Rng::seed_from_u64(1202);
    let mut worst = [0.0f64; 3];
    for delta in [0.0, 1e-9, 1e-6, 1e-3, 0.1] {
        for _ in 0..4 {
            let theta = 0.2 + 1.1 * rng.random::<f64>();
            let (c, s) = (theta.cos(), theta.sin());
            let q = DMatrix::from_row_slice(2, 2, &[c, -s, s, c]);
            let root_m = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![
                1.0 + rng.random::<f64>(),
                0.5 + rng.random::<f64>(),
            ]));
            let omega = [40.0, 40.0 * (1.0 + delta)];
            let zeta = [0.02, 0.02 + 0.03 * rng.random::<f64>()];
            let modal = |f: &dyn Fn(usize) -> f64| {
                &root_m
                    * &q
                    * DMatrix::from_fn(2, 2, |i, j| if i == j { f(i) } else { 0.0 })
                    * q.transpose()
                    * &root_m
            };
            let m = &root_m * &root_m;
            let k = modal(&|j| omega[j] * omega[j]);
            let r = modal(&|j| 2.0 * zeta[j] * omega[j]);
            let phi = root_m.clone().try_inverse().unwrap() * &q;
            for drive in 0..2 {
                let modes: Vec<Mode> = (0..2)
                    .map(|j| {
                        let wd = omega[j] * (1.0 - zeta[j] * zeta[j]).sqrt();
                        let pole = C64::new(-zeta[j] * omega[j], wd);
                        let residue = DMatrix::from_fn(2, 1, |i, _| {
                            pole * pole * phi[(i, j)] * phi[(drive, j)] / C64::new(0.0, 2.0 * wd)
                        });
                        oracle_mode(
                            pole,
                            zeta[j],
                            phi.column(j).map(|x| C64::new(x, 0.0)),
                            residue,
                        )
                    })
                    .collect();
                let mi = m.clone().try_inverse().unwrap();
                let d = mi.columns(drive, 1).into_owned();
                let params = MkrParams {
                    collocated: CollocatedPair {
                        output: drive,
                        input: 0,
                    },
                    ..MkrParams::default()
                };
                let fit = params.fit(&modes, &d).unwrap();
                assert!(!fit.polarity_flipped);
                let errors = mkr_errors(&fit, &m, &k, &r);
                for i in 0..3 {
                    worst[i] = worst[i].max(errors[i]);
                }
            }
        }
    }
    eprintln!("repeated/close: worst M, K, damping errors {worst:?}");
    // No pole differences enter MKR, so a repeated pole costs nothing: round-off of 2 x 2
    // inversions only; measured 7.2e-16 (M), 7.2e-16 (K), 8.7e-15 (damping).
    assert!(worst[0] < 1e-13, "M {:e}", worst[0]);
    assert!(worst[1] < 1e-13, "K {:e}", worst[1]);
    assert!(worst[2] < 1e-12, "damping {:e}", worst[2]);
}
