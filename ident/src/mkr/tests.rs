use super::*;
use crate::modal::{Intersample, ModalParams};
use crate::statespace::StateSpace;

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
