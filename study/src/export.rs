//! Exports for correlation with other tools: the identified modes as UFF
//! dataset 55 and the identified model's FRFs as UFF dataset 58 (function
//! type 4), through the writers of [`records::frf`].

use ident::frf::{Frf, FrfQuantity};
use ident::linalg::C64;
use nalgebra::DMatrix;
use records::frf::{ExportMode, FrfPoint, ModeShapeExport};

use crate::campaign_report::accelerance;

/// The modes (columns of `shapes`, one row per response point) with their
/// frequencies and damping ratios, each shape rotated so that its largest
/// component is real and positive, and its modal A from the modal mass
/// `Re(phi^T M phi)` of that shape under the identified `mass` (exact for
/// real modes; the written shape and A are consistent either way).
pub fn modes(
    points: &[FrfPoint],
    frequency_hz: &[f64],
    damping_ratio: &[f64],
    shapes: &DMatrix<C64>,
    mass: &DMatrix<f64>,
) -> ModeShapeExport {
    let modes = (0..shapes.ncols())
        .map(|j| {
            let col: Vec<C64> = shapes.column(j).iter().copied().collect();
            let big = col
                .iter()
                .copied()
                .max_by(|a, b| a.norm().total_cmp(&b.norm()))
                .unwrap_or(C64::new(1.0, 0.0));
            let rot = if big.norm() > 0.0 {
                big.conj() / big.norm()
            } else {
                C64::new(1.0, 0.0)
            };
            let shape: Vec<C64> = col.iter().map(|z| z * rot).collect();
            let real = DMatrix::from_fn(shape.len(), 1, |i, _| shape[i].re);
            let modal_mass = if mass.nrows() == shape.len() {
                (real.transpose() * mass * &real)[(0, 0)]
            } else {
                f64::NAN
            };
            ExportMode {
                frequency_hz: frequency_hz[j],
                damping_ratio: damping_ratio[j],
                modal_a: (modal_mass.is_finite() && modal_mass > 0.0).then(|| {
                    ExportMode::modal_a_from_mass(frequency_hz[j], damping_ratio[j], modal_mass)
                }),
                shape,
            }
        })
        .collect();
    ModeShapeExport {
        points: points.to_vec(),
        modes,
    }
}

/// The accelerance of `(mass, stiffness, damping)` on `frequency_hz` for a
/// unit force at each DOF of `reference_dofs`, outputs at every DOF, named
/// as given.
pub fn model_frf(
    (mass, stiffness, damping): (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>),
    reference_dofs: &[usize],
    frequency_hz: &[f64],
    outputs: &[String],
    references: &[String],
) -> Frf {
    let n = mass.nrows();
    let values = frequency_hz
        .iter()
        .map(|f| {
            let w = 2.0 * std::f64::consts::PI * f;
            let mut h = DMatrix::from_element(n, reference_dofs.len(), C64::new(0.0, 0.0));
            for (l, &dof) in reference_dofs.iter().enumerate() {
                // At 0 Hz the accelerance is 0 (a frame fixed to the ground).
                if w > 0.0 {
                    for (i, v) in accelerance(mass, stiffness, damping, dof, w)
                        .into_iter()
                        .enumerate()
                    {
                        h[(i, l)] = v;
                    }
                }
            }
            h
        })
        .collect();
    Frf {
        frequency_hz: frequency_hz.to_vec(),
        values,
        quantity: FrfQuantity::Accelerance,
        coherence: None,
        averages: None,
        outputs: outputs.to_vec(),
        references: references.to_vec(),
    }
}

/// The points of a campaign's outputs and inputs for FRF and mode files:
/// each channel's UFF node and direction when its file states them, else
/// node = DOF number (floor), direction +X; an input without them at its
/// collocated output's point.
pub fn record_points(
    files: &[records::RecordFile],
    c: &ident::Campaign,
    collocated: (usize, usize),
) -> (Vec<FrfPoint>, Vec<FrfPoint>) {
    let stated = |name: &str| {
        files
            .first()
            .and_then(|f| f.channels.iter().find(|ch| ch.name == name))
            .and_then(|ch| ch.node.zip(ch.direction))
    };
    let responses: Vec<FrfPoint> = c
        .outputs
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let (node, dir) = stated(n).unwrap_or((i as i64 + 1, 1));
            FrfPoint::named_at(n.as_str(), node, dir)
        })
        .collect();
    let references = c
        .inputs
        .iter()
        .enumerate()
        .map(|(l, n)| match stated(n) {
            Some((node, dir)) => FrfPoint::named_at(n.as_str(), node, dir),
            None if l == collocated.1 => {
                let (node, dir) = responses[collocated.0]
                    .node_dir()
                    .unwrap_or((collocated.0 as i64 + 1, 1));
                FrfPoint::named_at(n.as_str(), node, dir)
            }
            None => FrfPoint::named(n.as_str()),
        })
        .collect();
    (responses, references)
}

/// Writes `modes.uff` (UFF55: the modes of the model) and `model_frf.uff`
/// (UFF58: the model's accelerance for each placed reference on
/// `frequency_hz`) into `dir`, replacing a previous export.
#[allow(clippy::too_many_arguments)]
pub fn write_export(
    dir: &std::path::Path,
    responses: &[FrfPoint],
    references: &[(FrfPoint, usize)],
    frequencies_hz: &[f64],
    damping_ratios: &[f64],
    shapes: &DMatrix<C64>,
    model: (&DMatrix<f64>, &DMatrix<f64>, &DMatrix<f64>),
    grid_hz: &[f64],
) -> Result<(), crate::StudyError> {
    let out = fsio::OutputDir::create(dir, "modes.uff")?;
    let modes = self::modes(responses, frequencies_hz, damping_ratios, shapes, model.0);
    records::frf::write_uff55(&out.path().join("modes.uff"), &modes)?;
    let names: Vec<String> = responses.iter().map(|p| p.name.clone()).collect();
    let refs: Vec<String> = references.iter().map(|(p, _)| p.name.clone()).collect();
    let dofs: Vec<usize> = references.iter().map(|(_, d)| *d).collect();
    let frf = model_frf(model, &dofs, grid_hz, &names, &refs);
    let points: Vec<FrfPoint> = references.iter().map(|(p, _)| p.clone()).collect();
    let path = out.path().join("model_frf.uff");
    let file = records::frf::FrfFile::from_frf(&path, &frf, responses, &points);
    records::frf::write_frf(&path, &file, records::frf::FrfFormat::Uff58Ascii)?;
    out.commit()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_single_dof_gives_its_closed_form_and_modal_a() {
        // m = 2 kg, k = 800 N/m, c = 1.6 N s/m: w0 = 20 rad/s, zeta = 0.02.
        let (m, k, c) = (
            DMatrix::from_element(1, 1, 2.0),
            DMatrix::from_element(1, 1, 800.0),
            DMatrix::from_element(1, 1, 1.6),
        );
        let f = [1.0, 3.0, 5.0];
        let frf = model_frf((&m, &k, &c), &[0], &f, &["a".into()], &["f".into()]);
        for (k_, &fr) in f.iter().enumerate() {
            let w = 2.0 * std::f64::consts::PI * fr;
            let h = -w * w / C64::new(800.0 - w * w * 2.0, w * 1.6);
            assert!((frf.values[k_][(0, 0)] - h).norm() < 1e-15 * h.norm().max(1.0));
        }
        let shapes = DMatrix::from_element(1, 1, C64::new(0.0, -2.0));
        let f0 = 20.0 / (2.0 * std::f64::consts::PI);
        let e = modes(&[FrfPoint::at(1, 1)], &[f0], &[0.02], &shapes, &m);
        // The shape is rotated to +2 (real), modal mass 2 * 2^2 = 8 kg.
        assert_eq!(e.modes[0].shape[0], C64::new(2.0, 0.0));
        let a = e.modes[0].modal_a.unwrap();
        let expected = ExportMode::modal_a_from_mass(f0, 0.02, 8.0);
        assert!((a - expected).norm() < 1e-12 * expected.norm());
    }
}
