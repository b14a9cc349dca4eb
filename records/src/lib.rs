#![deny(missing_docs)]
//! Record files of vibration tests: sampled force and acceleration channels
//! as modal analyzers export them, channel selection into the identifier's
//! [`Campaign`](ident::Campaign), and the quality checks that judge records
//! before they are identified.
//!
//! - [`FileFormat`] is the one trait every format implements (detect from
//!   the content, read, write); [`FORMATS`] lists them in detection order:
//!   Universal File Format dataset 58 (ASCII and binary, [`Uff58`]) and
//!   delimited text ([`Csv`]).
//! - Readers return clean channels — equal length, finite values, one
//!   uniform sampling interval — in a [`RecordFile`], or a [`RecordError`]
//!   that names the file, the place in it (dataset, line, column, record
//!   field) and the problem. The format is recognised from the content,
//!   never from the file name.
//! - Writers replace their target atomically ([`write_atomically`]): a
//!   failed write never leaves a half-written file behind.
//! - [`select`] picks the force and acceleration channels of every file by
//!   [`ChannelSpec`]s into an [`ident::Campaign`].
//! - [`quality`] checks every hit: a hammer pulse, double hits, clipping,
//!   pulse length, decay, pre-trigger and SNR.
//! - [`consistency`] checks every hit against the others: dead and copied
//!   channels, spikes (named by line), duplicate records, level and
//!   spectrum against the campaign. A hit that is inconsistent with the
//!   others is never used silently.
//! - [`units`] is the one table of unit spellings the readers accept.
//! - [`frf`] reads and writes measured FRFs (UFF58 function type 4 with
//!   coherence 6, ASCII and binary; CSV with a header convention; the
//!   headerless `freq; H1; ...` Python-complex notation), in SI units, and
//!   collates the pairs of several files into one [`ident::Frf`]
//!   ([`frf::assemble`]); [`content_kind`] tells time records from FRFs by
//!   content; [`frf::write_uff55`] writes identified modes as UFF dataset 55.
//!
//! # Conventions
//!
//! Times in seconds (`dt_s`, `start_s`), rates in hertz (`fs_hz`); channel
//! values are kept in the unit the file states ([`Channel::unit`]). UFF
//! directions are `1..6 = +X, +Y, +Z, +RX, +RY, +RZ`, negative for minus,
//! 0 for a scalar. Channel positions in messages are 1-based (`#2`).
//!
//! # Example
//!
//! ```
//! use records::{ChannelSpec, Csv, FileFormat, ReadOptions, select};
//! use std::path::Path;
//!
//! let text = "time [s],force [N],acc1 [m/s^2],acc2 [m/s^2]\n\
//!             0.0,0.0,0.0,0.0\n0.5,2.0,0.1,0.0\n1.0,0.0,-0.3,0.2\n1.5,0.0,0.2,-0.1\n";
//! let rec = Csv.read(text.as_bytes(), Path::new("hit01.csv"), &ReadOptions::default())?;
//! assert_eq!(rec.dt_s, 0.5);
//! assert_eq!(rec.channels[0].unit.as_deref(), Some("N"));
//!
//! let force: ChannelSpec = "force".parse()?;
//! let campaign = select(&[rec], &[force], None)?;
//! assert_eq!(campaign.outputs, ["acc1", "acc2"]);
//! assert_eq!(campaign.records[0].outputs[(0, 2)], -0.3);
//! # Ok::<(), records::RecordError>(())
//! ```
//!
//! FRFs: the unit in the header converts to SI (1 g = 9.80665 m/s^2), and
//! the driving point is found from node and direction.
//!
//! ```
//! use records::{AssembleOptions, ContentKind, FrfReadOptions, content_kind, frf, parse_frf};
//! use std::path::Path;
//!
//! let text = "frequency_hz,re H(acc@2:+X/hammer@2:+X) [g/N],im H(acc@2:+X/hammer@2:+X) [g/N]\n\
//!             10,0.5,-1.0\n20,0.25,-0.5\n";
//! assert_eq!(content_kind(text.as_bytes()), ContentKind::Frf);
//! let file = parse_frf(text.as_bytes(), Path::new("h.csv"), &FrfReadOptions::default())?;
//! assert_eq!(file.pairs[0].values[0].re, 0.5 * 9.80665);
//! let set = frf::assemble(&[file], &AssembleOptions::default())?;
//! assert_eq!((set.frf.outputs_count(), set.frf.references_count()), (1, 1));
//! assert_eq!((set.collocated[0].output, set.collocated[0].input), (0, 0));
//! # Ok::<(), records::RecordError>(())
//! ```

pub mod consistency;
mod csv;
mod error;
mod format;
pub mod frf;
pub mod numfmt;
pub mod quality;
pub mod realization;
mod record;
mod select;
mod spec;
mod timeaxis;
mod uff;
pub mod units;
mod write;

pub use crate::csv::{parse_csv, parse_csv_from};
pub use crate::error::{CampaignMismatch, IoOp, Location, Problem, RecordError};
pub use crate::format::{
    CAMPAIGN_DT_REL_TOL, Csv, FORMATS, FileFormat, MAX_FILE_BYTES, Uff58, check_campaign, detect,
    parse_record, read_campaign, read_record, read_records, write_csv, write_record, write_uff58,
};
pub use crate::frf::{
    AssembleOptions, ContentKind, FrfFile, FrfFormat, FrfPair, FrfPoint, FrfReadOptions, FrfSet,
    content_kind, encode_frf, parse_frf, read_content_kind, read_frf, write_frf,
};
pub use crate::record::{Channel, Format, ReadOptions, RecordFile, SampleLines};
pub use crate::select::select;
pub use crate::spec::{ChannelSpec, direction_label, parse_direction};
pub use crate::uff::{Uff58Encoding, parse_uff58};
pub use crate::write::write_atomically;
