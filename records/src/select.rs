//! Channel selection: record files into one [`Campaign`].
//!
//! The input (force) channels and the output (acceleration) channels are
//! chosen by [`ChannelSpec`]s on the first file; every other file must have
//! channels of the same names. Outputs default to every channel that is not
//! an input, in file order, and are in DOF order.
//!
//! Values are taken in SI: a channel's declared unit (`force [kN]`,
//! `acc1 [g]`, a UFF ordinate label) is converted, forces to N and
//! accelerations to m/s^2, each file by its own units. A unit that is not a
//! force (inputs) or an acceleration (outputs), such as a displacement or a
//! voltage, is refused naming the file and the channel: read as N or m/s^2
//! it would scale M, K and R by its factor without a sign of it. A channel
//! without a unit is taken to be in N or m/s^2.

use ident::{Campaign, FrfQuantity, Record};
use nalgebra::DMatrix;

use crate::error::RecordError;
use crate::format::check_campaign;
use crate::record::RecordFile;
use crate::spec::ChannelSpec;
use crate::units;

/// Selects `inputs` and `outputs` (default: every other channel) from the
/// records of one campaign, after checking that they share length and
/// sampling interval. Record labels are the file paths.
pub fn select(
    files: &[RecordFile],
    inputs: &[ChannelSpec],
    outputs: Option<&[ChannelSpec]>,
) -> Result<Campaign, RecordError> {
    check_campaign(files)?;
    let first = &files[0];
    let input_idx: Vec<usize> = inputs
        .iter()
        .map(|s| first.channel_index(s))
        .collect::<Result<_, _>>()?;
    let output_idx: Vec<usize> = match outputs {
        Some(list) => list
            .iter()
            .map(|s| first.channel_index(s))
            .collect::<Result<_, _>>()?,
        None => (0..first.channels.len())
            .filter(|i| !input_idx.contains(i))
            .collect(),
    };
    if output_idx.is_empty() {
        return Err(RecordError::NoOutputs {
            path: first.path.clone(),
        });
    }
    if let Some(i) = output_idx.iter().find(|i| input_idx.contains(i)) {
        return Err(RecordError::OutputIsInput {
            path: first.path.clone(),
            channel: first.channels[*i].name.clone(),
        });
    }
    let names = |idx: &[usize]| -> Vec<String> {
        idx.iter()
            .map(|&i| first.channels[i].name.clone())
            .collect()
    };
    let (input_names, output_names) = (names(&input_idx), names(&output_idx));
    let mut records = Vec::with_capacity(files.len());
    for (k, r) in files.iter().enumerate() {
        // Every file must have the selected channels under the same names.
        let pick = |idx: &[usize], names: &[String]| -> Result<Vec<usize>, RecordError> {
            if k == 0 {
                return Ok(idx.to_vec());
            }
            names
                .iter()
                .map(|n| r.channel_index(&ChannelSpec::Name(n.clone())))
                .collect()
        };
        let ins = pick(&input_idx, &input_names)?;
        let outs = pick(&output_idx, &output_names)?;
        let scales = |idx: &[usize], input: bool| -> Result<Vec<f64>, RecordError> {
            idx.iter().map(|&i| si_factor(r, i, input)).collect()
        };
        let (in_scale, out_scale) = (scales(&ins, true)?, scales(&outs, false)?);
        let n = r.len();
        // A factor of 1 (SI, or no unit) leaves every value bit for bit.
        let inputs = DMatrix::from_fn(ins.len(), n, |i, s| {
            r.channels[ins[i]].values[s] * in_scale[i]
        });
        let outputs = DMatrix::from_fn(outs.len(), n, |i, s| {
            r.channels[outs[i]].values[s] * out_scale[i]
        });
        records.push(Record::new(inputs, outputs));
    }
    Ok(Campaign::named(
        records,
        first.dt_s,
        input_names,
        output_names,
        files.iter().map(|f| f.path.display().to_string()).collect(),
    ))
}

/// The factor that brings channel `index` of `file` to SI from its declared
/// unit: newtons for an input, m/s^2 for an output; 1 without a unit.
fn si_factor(file: &RecordFile, index: usize, input: bool) -> Result<f64, RecordError> {
    let channel = &file.channels[index];
    let Some(unit) = channel.unit.as_deref() else {
        return Ok(1.0);
    };
    let refuse = |problem: &str| RecordError::ChannelUnit {
        path: file.path.clone(),
        channel: channel.describe(index),
        unit: unit.to_string(),
        input,
        problem: problem.to_string(),
    };
    if input {
        return units::newtons_per(unit).ok_or_else(|| refuse("not a force unit"));
    }
    match units::motion_unit(unit) {
        Some((FrfQuantity::Accelerance, factor)) => Ok(factor),
        Some((FrfQuantity::Receptance, _)) => Err(refuse("a displacement unit")),
        Some((FrfQuantity::Mobility, _)) => Err(refuse("a velocity unit")),
        None => Err(refuse("not an acceleration unit")),
    }
}
