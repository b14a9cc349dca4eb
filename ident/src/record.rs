//! Input/output records (hits) and their validation.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};
use std::fmt;

/// One test record: `inputs` is r x N (forces, N), `outputs` is m x N (accelerations,
/// m/s^2), one column per sample. The structure is assumed at rest before the first
/// sample (zero initial conditions).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// r x N input samples.
    pub inputs: DMatrix<f64>,
    /// m x N output samples; output `i` is degree of freedom `i`.
    pub outputs: DMatrix<f64>,
}

impl Record {
    /// Wraps inputs (r x N) and outputs (m x N). Lengths are checked by [`validate`], so
    /// records read from files can be built first and rejected with a typed error.
    pub fn new(inputs: DMatrix<f64>, outputs: DMatrix<f64>) -> Self {
        Self { inputs, outputs }
    }

    /// Number of samples (columns of `outputs`).
    pub fn len(&self) -> usize {
        self.outputs.ncols()
    }

    /// True for a record without samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A channel of a record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Channel {
    /// Input (force) channel.
    Input(usize),
    /// Output (acceleration) channel.
    Output(usize),
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Channel::Input(i) => write!(f, "input {i}"),
            Channel::Output(i) => write!(f, "output {i}"),
        }
    }
}

/// Ways a set of records can be unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DataError {
    /// No record was given.
    #[error("no records were given")]
    NoRecords,
    /// The sample interval is not a positive finite number.
    #[error("sample interval dt_s = {dt_s} must be positive and finite")]
    InvalidSampleInterval {
        /// The sample interval given (s).
        dt_s: f64,
    },
    /// A record has no input or no output channel.
    #[error(
        "record {record} has {inputs} input and {outputs} output channels; both must be at least 1"
    )]
    NoChannels {
        /// The record (hit), 0-based in the order given.
        record: usize,
        /// Its input channels (rows of `inputs`).
        inputs: usize,
        /// Its output channels (rows of `outputs`).
        outputs: usize,
    },
    /// Input and output sample counts differ within a record.
    #[error(
        "record {record} has {input_samples} input samples but {output_samples} output samples"
    )]
    LengthMismatch {
        /// The record (hit), 0-based in the order given.
        record: usize,
        /// Samples of its inputs (columns of `inputs`).
        input_samples: usize,
        /// Samples of its outputs (columns of `outputs`).
        output_samples: usize,
    },
    /// A record's channel counts differ from those of record 0.
    #[error(
        "record {record} has {inputs} inputs and {outputs} outputs, record 0 has {expected_inputs} and {expected_outputs}"
    )]
    ChannelCountMismatch {
        /// The record (hit), 0-based in the order given.
        record: usize,
        /// Its input channels.
        inputs: usize,
        /// Its output channels.
        outputs: usize,
        /// Input channels of record 0.
        expected_inputs: usize,
        /// Output channels of record 0.
        expected_outputs: usize,
    },
    /// A sample is NaN or infinite.
    #[error("record {record}, {channel}, sample {sample} is not finite ({value})")]
    NonFinite {
        /// The record (hit), 0-based in the order given.
        record: usize,
        /// The channel holding the first non-finite sample.
        channel: Channel,
        /// The sample (0-based column).
        sample: usize,
        /// Its value (NaN or an infinity).
        value: f64,
    },
    /// Every input sample of a record is zero: the record carries no input-output
    /// information (and violates the at-rest assumption if the outputs move).
    #[error("record {record} has no excitation: all its input samples are zero")]
    NoExcitation {
        /// The record (hit), 0-based in the order given.
        record: usize,
    },
    /// An output channel is zero in every record: that degree of freedom is unobserved.
    #[error("{channel} is zero in every record")]
    DeadChannel {
        /// The output channel that never moves.
        channel: Channel,
    },
    /// A record is too short for the requested orders.
    #[error("record {record} has {samples} samples, {required} are required ({reason})")]
    TooShort {
        /// The record (hit), 0-based in the order given.
        record: usize,
        /// Its samples.
        samples: usize,
        /// Samples needed.
        required: usize,
        /// What needs them (e.g. `"one Welch segment"`, the OKID regression).
        reason: &'static str,
    },
}

/// Channel counts shared by a valid set of records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecordShape {
    /// Number of inputs r.
    pub inputs: usize,
    /// Number of outputs m.
    pub outputs: usize,
    /// Length of the longest record.
    pub longest: usize,
    /// Index of the longest record.
    pub longest_record: usize,
    /// Total number of samples over all records.
    pub total_samples: usize,
}

/// Checks that the records are consistent, finite, excited and that no output channel is
/// dead. Returns their shared shape.
pub fn validate(records: &[Record]) -> Result<RecordShape, DataError> {
    let first = records.first().ok_or(DataError::NoRecords)?;
    let (r, m) = (first.inputs.nrows(), first.outputs.nrows());
    let mut longest = 0;
    let mut longest_record = 0;
    let mut total = 0;
    let mut output_alive = vec![false; m];
    for (index, rec) in records.iter().enumerate() {
        let (ri, mi) = (rec.inputs.nrows(), rec.outputs.nrows());
        if ri == 0 || mi == 0 {
            return Err(DataError::NoChannels {
                record: index,
                inputs: ri,
                outputs: mi,
            });
        }
        if ri != r || mi != m {
            return Err(DataError::ChannelCountMismatch {
                record: index,
                inputs: ri,
                outputs: mi,
                expected_inputs: r,
                expected_outputs: m,
            });
        }
        if rec.inputs.ncols() != rec.outputs.ncols() {
            return Err(DataError::LengthMismatch {
                record: index,
                input_samples: rec.inputs.ncols(),
                output_samples: rec.outputs.ncols(),
            });
        }
        let n = rec.len();
        for (mat, is_input) in [(&rec.inputs, true), (&rec.outputs, false)] {
            for sample in 0..n {
                for ch in 0..mat.nrows() {
                    let value = mat[(ch, sample)];
                    if !value.is_finite() {
                        return Err(DataError::NonFinite {
                            record: index,
                            channel: if is_input {
                                Channel::Input(ch)
                            } else {
                                Channel::Output(ch)
                            },
                            sample,
                            value,
                        });
                    }
                }
            }
        }
        if rec.inputs.iter().all(|&x| x == 0.0) {
            return Err(DataError::NoExcitation { record: index });
        }
        for (ch, alive) in output_alive.iter_mut().enumerate() {
            *alive |= rec.outputs.row(ch).iter().any(|&x| x != 0.0);
        }
        if n > longest {
            longest = n;
            longest_record = index;
        }
        total += n;
    }
    if let Some(ch) = output_alive.iter().position(|&a| !a) {
        return Err(DataError::DeadChannel {
            channel: Channel::Output(ch),
        });
    }
    Ok(RecordShape {
        inputs: r,
        outputs: m,
        longest,
        longest_record,
        total_samples: total,
    })
}

/// Checks a sample interval.
pub fn validate_dt(dt_s: f64) -> Result<(), DataError> {
    if dt_s.is_finite() && dt_s > 0.0 {
        Ok(())
    } else {
        Err(DataError::InvalidSampleInterval { dt_s })
    }
}
