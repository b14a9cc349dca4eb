//! Identified modes as UFF dataset 55: the records as the format lays
//! them out, and a round trip to the printed precision.

use std::path::Path;

use ident::linalg::C64;
use records::FrfPoint;
use records::frf::{ExportMode, ModeShapeExport, encode_uff55, parse_uff55};

fn sample() -> ModeShapeExport {
    ModeShapeExport {
        points: vec![
            FrfPoint::at(1, 1),
            FrfPoint::at(2, 1),
            FrfPoint::at(3, 1),
            FrfPoint::at(3, -2),
        ],
        modes: vec![
            ExportMode {
                frequency_hz: 2.0,
                damping_ratio: 0.05,
                shape: vec![
                    C64::new(0.445, 0.01),
                    C64::new(0.802, -0.02),
                    C64::new(1.0, 0.0),
                    C64::new(0.125, 0.5),
                ],
                modal_a: Some(ExportMode::modal_a_from_mass(2.0, 0.05, 3.5)),
            },
            ExportMode {
                frequency_hz: 5.612345678,
                damping_ratio: 0.0123456789,
                shape: vec![
                    C64::new(-1.0, 0.0),
                    C64::new(-0.555, 0.003),
                    C64::new(1.247, -0.1),
                    C64::new(0.0, 0.0),
                ],
                modal_a: None,
            },
        ],
    }
}

#[test]
fn records_follow_the_layout() {
    let text = String::from_utf8(encode_uff55(&sample()).unwrap()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "    -1");
    assert_eq!(lines[1], "    55");
    assert_eq!(lines[6].trim_end(), "frameid mode=1 f_hz=2 zeta=0.05");
    // Record 6: structural, complex eigenvalue first order, 3-DOF
    // translation, displacement, complex, 3 values per node.
    assert_eq!(
        lines[7],
        "         1         3         2         8         5         3"
    );
    assert_eq!(lines[8], "         2         6         1         1");
    // Record 8: lambda = -zeta w + i w sqrt(1 - zeta^2), w = 4 pi =
    // 12.566371, sqrt(0.9975) = 0.99874922: -0.628319 + 12.550653i;
    // A = 2 i w_d m = 2 * 12.550653 * 3.5 i = 87.854571i;
    // B = -lambda A = 12.550653 * 87.854571 + 0.628319 * 87.854571 i
    //   = 1102.632 + 55.2007i.
    assert_eq!(
        lines[9],
        " -6.28319E-01  1.25507E+01  0.00000E+00  8.78546E+01  1.10263E+03  5.52007E+01"
    );
    // Node 1: X only; node 3: X and -Y (negated).
    assert_eq!(lines[10], "         1");
    assert_eq!(
        lines[11],
        "  4.45000E-01  1.00000E-02  0.00000E+00  0.00000E+00  0.00000E+00  0.00000E+00"
    );
    assert_eq!(lines[14], "         3");
    assert_eq!(
        lines[15],
        "  1.00000E+00  0.00000E+00 -1.25000E-01 -5.00000E-01  0.00000E+00  0.00000E+00"
    );
    assert_eq!(lines[16], "    -1");
}

#[test]
fn round_trip_to_the_printed_precision() {
    let modes = sample();
    let bytes = encode_uff55(&modes).unwrap();
    let back = parse_uff55(&bytes, Path::new("modes.uff")).unwrap();
    // Node 3 direction -2 comes back as +2 with the component negated.
    let want_points = [
        FrfPoint::at(1, 1),
        FrfPoint::at(2, 1),
        FrfPoint::at(3, 1),
        FrfPoint::at(3, 2),
    ];
    assert_eq!(back.points, want_points);
    assert_eq!(back.modes.len(), 2);
    for (m, b) in modes.modes.iter().zip(&back.modes) {
        // Exact: ID line 5 carries them in full.
        assert_eq!(b.frequency_hz, m.frequency_hz);
        assert_eq!(b.damping_ratio, m.damping_ratio);
        for (i, (z, y)) in m.shape.iter().zip(&b.shape).enumerate() {
            let z = if i == 3 { -z } else { *z };
            // E13.5: 6 significant digits per part, half a unit of the
            // 6th digit is 5e-6 of the part; parts here are at most 1.25.
            assert!((z - y).norm() <= 1e-5, "component {i}: {z} vs {y}");
        }
        match (m.modal_a, b.modal_a) {
            (Some(a), Some(c)) => assert!((a - c).norm() <= 5e-6 * a.norm()),
            (None, None) => {}
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn writer_refuses_points_without_place() {
    let mut modes = sample();
    modes.points[1] = FrfPoint::named("acc2");
    let e = encode_uff55(&modes).unwrap_err();
    assert!(
        e.contains("point #2 (acc2) has no node and direction"),
        "{e}"
    );
    let mut modes = sample();
    modes.points[1] = FrfPoint::at(1, 1);
    let e = encode_uff55(&modes).unwrap_err();
    assert!(
        e.contains("points #1 and #2 are both at node 1 direction X"),
        "{e}"
    );
    let mut modes = sample();
    modes.modes[1].damping_ratio = 1.5;
    let e = encode_uff55(&modes).unwrap_err();
    assert!(e.contains("mode 2: damping ratio 1.5"), "{e}");
}
