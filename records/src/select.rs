//! Channel selection: record files into one [`Campaign`].
//!
//! The input (force) channels and the output (acceleration) channels are
//! chosen by [`ChannelSpec`]s on the first file; every other file must have
//! channels of the same names. Outputs default to every channel that is not
//! an input, in file order, and are in DOF order.

use ident::{Campaign, Record};
use nalgebra::DMatrix;

use crate::error::RecordError;
use crate::format::check_campaign;
use crate::record::RecordFile;
use crate::spec::ChannelSpec;

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
        let n = r.len();
        let inputs = DMatrix::from_fn(ins.len(), n, |i, s| r.channels[ins[i]].values[s]);
        let outputs = DMatrix::from_fn(outs.len(), n, |i, s| r.channels[outs[i]].values[s]);
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
