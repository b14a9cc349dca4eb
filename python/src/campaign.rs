//! `frameid.Campaign` (the hits of one test set-up) and `read_records`.

use std::path::PathBuf;

use nalgebra::DMatrix;
use numpy::ndarray::{Array3, ArrayD};
use numpy::{IntoPyArray, PyArray3};
use pyo3::prelude::*;
use records::{ChannelSpec, ReadOptions, RecordFile, SampleLines};
use serde::{Deserialize, Serialize};

use crate::arrays::f64_array;
use crate::{Reduced, error, from_state, guard, lib_error, reduce, to_state};

/// The hits of one test set-up: force and acceleration records sampled
/// every ``dt_s`` seconds, with channel and hit names.
///
/// ``Campaign(force, acc, dt_s)`` takes numpy arrays: ``force`` of shape
/// ``(hits, inputs, samples)`` in newtons and ``acc`` of shape
/// ``(hits, outputs, samples)`` in m/s², one accelerometer per floor in
/// floor order. Optional ``inputs``, ``outputs`` (channel names; default
/// ``force`` or ``force1, force2, ...`` and ``acc1, acc2, ...``) and
/// ``labels`` (hit names used in messages; default ``hit 1, hit 2, ...``).
/// Every sample must be finite. ``read_records`` builds one from files.
#[pyclass(module = "frameid", frozen)]
pub struct Campaign {
    pub inner: ident::Campaign,
    /// For records read from files: where every sample was in them (without
    /// the samples), so that messages name the line of a sample as the
    /// command line's do. `None` for campaigns built from arrays.
    pub files: Option<Vec<FileMeta>>,
}

/// What a record file said besides its samples: its path, layout, timing
/// and channels with the lines that held their samples (a serializable
/// copy of `records::RecordFile` without the values).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FileMeta {
    path: PathBuf,
    format: FormatMeta,
    dt_s: f64,
    start_s: f64,
    channels: Vec<ChannelMeta>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
enum FormatMeta {
    Csv { delimiter: u8 },
    Uff58Ascii,
    Uff58Binary,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct ChannelMeta {
    name: String,
    unit: Option<String>,
    node: Option<i64>,
    direction: Option<i32>,
    id_line: Option<String>,
    lines: Option<SampleLines>,
}

impl FileMeta {
    fn of(f: &RecordFile) -> FileMeta {
        FileMeta {
            path: f.path.clone(),
            format: match f.format {
                records::Format::Csv { delimiter } => FormatMeta::Csv { delimiter },
                records::Format::Uff58Ascii => FormatMeta::Uff58Ascii,
                records::Format::Uff58Binary => FormatMeta::Uff58Binary,
            },
            dt_s: f.dt_s,
            start_s: f.start_s,
            channels: f
                .channels
                .iter()
                .map(|c| ChannelMeta {
                    name: c.name.clone(),
                    unit: c.unit.clone(),
                    node: c.node,
                    direction: c.direction,
                    id_line: c.id_line.clone(),
                    lines: c.lines.clone(),
                })
                .collect(),
        }
    }

    /// The record file again, without samples (what messages need).
    pub fn record_file(&self) -> RecordFile {
        RecordFile {
            path: self.path.clone(),
            format: match self.format {
                FormatMeta::Csv { delimiter } => records::Format::Csv { delimiter },
                FormatMeta::Uff58Ascii => records::Format::Uff58Ascii,
                FormatMeta::Uff58Binary => records::Format::Uff58Binary,
            },
            dt_s: self.dt_s,
            start_s: self.start_s,
            channels: self
                .channels
                .iter()
                .map(|c| records::Channel {
                    name: c.name.clone(),
                    unit: c.unit.clone(),
                    node: c.node,
                    direction: c.direction,
                    id_line: c.id_line.clone(),
                    values: Vec::new(),
                    lines: c.lines.clone(),
                })
                .collect(),
        }
    }
}

/// The pickled form of a campaign.
#[derive(Debug, Serialize, Deserialize)]
struct CampaignState {
    campaign: ident::Campaign,
    files: Option<Vec<FileMeta>>,
}

/// Default channel names: `base` for one channel, `base1, base2, ...` for
/// more (`always_number`: numbered even for one).
fn default_names(base: &str, count: usize, always_number: bool) -> Vec<String> {
    if count == 1 && !always_number {
        return vec![base.to_string()];
    }
    (1..=count).map(|i| format!("{base}{i}")).collect()
}

/// Checks a (hits, channels, samples) array: its dimensions and that every
/// sample is finite. Returns (hits, channels, samples).
fn check_records(what: &str, a: &ArrayD<f64>, channels: &str) -> PyResult<(usize, usize, usize)> {
    let shape = a.shape();
    if shape.len() != 3 {
        return Err(error(format!(
            "{what}: expected an array of shape (hits, {channels}, samples), got {} dimension(s) of shape {shape:?}{}",
            shape.len(),
            if shape.len() == 2 {
                format!("; for one channel use {what}[:, None, :]")
            } else {
                String::new()
            }
        )));
    }
    let (h, c, n) = (shape[0], shape[1], shape[2]);
    if h == 0 || c == 0 || n == 0 {
        return Err(error(format!(
            "{what}: shape {shape:?} is empty: need at least one hit, one channel and one sample"
        )));
    }
    if let Some((index, value)) = a.indexed_iter().find(|(_, v)| !v.is_finite()) {
        return Err(error(format!(
            "{what}[{}, {}, {}] is not finite ({value}): hit {}, {} channel {}, sample {}",
            index[0],
            index[1],
            index[2],
            index[0] + 1,
            if what == "force" { "input" } else { "output" },
            index[1] + 1,
            index[2]
        )));
    }
    Ok((h, c, n))
}

/// Checks a list of names: `count` of them, none twice.
fn check_names(what: &str, names: Vec<String>, count: usize, of: &str) -> PyResult<Vec<String>> {
    if names.len() != count {
        return Err(error(format!(
            "{what}: {} name(s) for {count} {of}",
            names.len()
        )));
    }
    for (i, n) in names.iter().enumerate() {
        if names[..i].contains(n) {
            return Err(error(format!("{what}: '{n}' appears twice")));
        }
    }
    Ok(names)
}

impl Campaign {
    pub fn from_state(state: &[u8]) -> PyResult<Self> {
        let s: CampaignState = from_state(state)?;
        Ok(Campaign {
            inner: s.campaign,
            files: s.files,
        })
    }

    /// A campaign built in memory (no files behind it).
    pub fn from_ident(inner: ident::Campaign) -> Self {
        Campaign { inner, files: None }
    }

    /// One (hits, channels, samples) array of the inputs or outputs.
    fn stack<'py>(&self, py: Python<'py>, outputs: bool) -> Bound<'py, PyArray3<f64>> {
        let c = &self.inner;
        let mats: Vec<&DMatrix<f64>> = c
            .records
            .iter()
            .map(|r| if outputs { &r.outputs } else { &r.inputs })
            .collect();
        let channels = if outputs {
            c.outputs.len()
        } else {
            c.inputs.len()
        };
        // Campaigns are rectangular (built from arrays, or from files that
        // `records::select` has checked to share one length); NaN would pad
        // a shorter record.
        Array3::from_shape_fn((mats.len(), channels, c.longest()), |(h, i, k)| {
            mats[h].get((i, k)).copied().unwrap_or(f64::NAN)
        })
        .into_pyarray(py)
    }
}

#[pymethods]
impl Campaign {
    #[new]
    #[pyo3(signature = (force, acc, dt_s, *, inputs=None, outputs=None, labels=None))]
    fn new(
        py: Python<'_>,
        force: &Bound<'_, PyAny>,
        acc: &Bound<'_, PyAny>,
        dt_s: f64,
        inputs: Option<Vec<String>>,
        outputs: Option<Vec<String>>,
        labels: Option<Vec<String>>,
    ) -> PyResult<Self> {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(error(format!(
                "dt_s: must be a positive, finite sampling interval in seconds, got {dt_s}"
            )));
        }
        let f = f64_array(py, force, "force")?;
        let a = f64_array(py, acc, "acc")?;
        let (hits, r, n) = check_records("force", &f, "inputs")?;
        let (acc_hits, m, acc_n) = check_records("acc", &a, "outputs")?;
        if acc_hits != hits || acc_n != n {
            return Err(error(format!(
                "acc: shape {:?} does not match force {:?}: both need the same hits and samples",
                a.shape(),
                f.shape()
            )));
        }
        let inputs = match inputs {
            Some(names) => check_names("inputs", names, r, "force channel(s)")?,
            None => default_names("force", r, false),
        };
        let outputs = match outputs {
            Some(names) => check_names("outputs", names, m, "acceleration channel(s)")?,
            None => default_names("acc", m, true),
        };
        let labels = match labels {
            Some(names) => check_names("labels", names, hits, "hit(s)")?,
            None => (1..=hits).map(|h| format!("hit {h}")).collect(),
        };
        let records = (0..hits)
            .map(|h| {
                ident::Record::new(
                    DMatrix::from_fn(r, n, |i, k| f[[h, i, k]]),
                    DMatrix::from_fn(m, n, |i, k| a[[h, i, k]]),
                )
            })
            .collect();
        Ok(Campaign::from_ident(ident::Campaign::named(
            records, dt_s, inputs, outputs, labels,
        )))
    }

    /// Forces, shape ``(hits, inputs, samples)``, N.
    #[getter]
    fn force<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        self.stack(py, false)
    }

    /// Accelerations, shape ``(hits, outputs, samples)``, m/s².
    #[getter]
    fn acc<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        self.stack(py, true)
    }

    /// Sampling interval, s.
    #[getter]
    fn dt_s(&self) -> f64 {
        self.inner.dt_s
    }

    /// Sampling rate, Hz.
    #[getter]
    fn fs_hz(&self) -> f64 {
        1.0 / self.inner.dt_s
    }

    /// Input (force) channel names.
    #[getter]
    fn inputs(&self) -> Vec<String> {
        self.inner.inputs.clone()
    }

    /// Output (acceleration) channel names, in floor order.
    #[getter]
    fn outputs(&self) -> Vec<String> {
        self.inner.outputs.clone()
    }

    /// Hit names (the files for records read from files).
    #[getter]
    fn labels(&self) -> Vec<String> {
        self.inner.labels.clone()
    }

    /// Number of hits.
    #[getter]
    fn hits(&self) -> usize {
        self.inner.len()
    }

    /// Samples per hit.
    #[getter]
    fn samples(&self) -> usize {
        self.inner.longest()
    }

    /// The campaign restricted to the hits ``indices`` (zero-based, in the
    /// order given).
    fn subset(&self, indices: Vec<usize>) -> PyResult<Campaign> {
        if indices.is_empty() {
            return Err(error("indices: need at least one hit"));
        }
        if let Some(&i) = indices.iter().find(|&&i| i >= self.inner.len()) {
            return Err(error(format!(
                "indices: hit {i} is out of range; there are {} hits (zero-based)",
                self.inner.len()
            )));
        }
        Ok(Campaign {
            inner: self.inner.subset(&indices),
            files: self
                .files
                .as_ref()
                .map(|f| indices.iter().map(|&i| f[i].clone()).collect()),
        })
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __repr__(&self) -> String {
        let c = &self.inner;
        format!(
            "Campaign({} hits of {} samples at {} Hz; inputs {}; outputs {})",
            c.len(),
            c.longest(),
            1.0 / c.dt_s,
            c.inputs.join(", "),
            c.outputs.join(", ")
        )
    }

    /// Equal samples, sampling interval and names (labels included).
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Campaign>()
            .is_ok_and(|o| o.get().inner == self.inner)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> Reduced<'py> {
        let state = CampaignState {
            campaign: self.inner.clone(),
            files: self.files.clone(),
        };
        reduce(py, "Campaign", to_state(py, &state)?)
    }
}

/// Paths: one path-like or a sequence of them.
fn extract_paths(obj: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    if let Ok(p) = obj.extract::<PathBuf>() {
        return Ok(vec![p]);
    }
    obj.extract::<Vec<PathBuf>>().map_err(|_| {
        error("paths: expected a path or a sequence of paths (str or os.PathLike), one record file per hit")
    })
}

/// Channel selectors: `a,b` or a sequence of strings; `what` names the
/// argument.
pub fn extract_specs(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<ChannelSpec>> {
    let texts: Vec<String> = if let Ok(s) = obj.extract::<String>() {
        s.split(',').map(str::to_string).collect()
    } else {
        obj.extract::<Vec<String>>().map_err(|_| {
            error(format!(
                "{what}: expected a channel name or a sequence of them"
            ))
        })?
    };
    if texts.is_empty() {
        return Err(error(format!("{what}: no channel given")));
    }
    texts
        .iter()
        .map(|t| {
            t.parse::<ChannelSpec>()
                .map_err(|e| crate::lib_error_in(what, e))
        })
        .collect()
}

/// Reads record files, one per hit (CSV or UFF dataset 58, ASCII or binary,
/// detected from the content), and selects the channels, as
/// ``frameid identify FILES`` does.
///
/// ``input``: the force channel(s) by name (``"force"``), ``node:direction``
/// for UFF (``"1:+X"``), ``"id:TEXT"`` or ``"#k"``; a comma-separated
/// string or a sequence. ``outputs``: the accelerometers in floor order
/// (default: every other channel, in file order). ``fs``: sampling rate in
/// Hz for files without a time column. Hit labels are the paths as given.
#[pyfunction]
#[pyo3(signature = (paths, input=None, outputs=None, *, fs=None))]
fn read_records(
    py: Python<'_>,
    paths: &Bound<'_, PyAny>,
    input: Option<&Bound<'_, PyAny>>,
    outputs: Option<&Bound<'_, PyAny>>,
    fs: Option<f64>,
) -> PyResult<Campaign> {
    if let Some(fs) = fs
        && !(fs.is_finite() && fs > 0.0)
    {
        return Err(error(format!(
            "fs: must be a positive sampling rate in Hz, got {fs}"
        )));
    }
    let paths = extract_paths(paths)?;
    if paths.is_empty() {
        return Err(error("no record files given"));
    }
    let inputs = match input {
        Some(i) => extract_specs(i, "input")?,
        None => vec![ChannelSpec::Name("force".into())],
    };
    let outputs = outputs.map(|o| extract_specs(o, "outputs")).transpose()?;
    py.detach(|| {
        guard(|| {
            let opts = ReadOptions { fs_hz: fs };
            let files: Vec<RecordFile> = records::read_records(&paths, &opts).map_err(lib_error)?;
            let inner = records::select(&files, &inputs, outputs.as_deref()).map_err(lib_error)?;
            Ok(Campaign {
                inner,
                files: Some(files.iter().map(FileMeta::of).collect()),
            })
        })
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Campaign>()?;
    m.add_function(wrap_pyfunction!(read_records, m)?)?;
    Ok(())
}
