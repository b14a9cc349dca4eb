//! Command-line interface definitions (clap). `main.rs` parses and
//! dispatches; each subcommand lives in [`crate::commands`].

use std::path::PathBuf;

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand, ValueEnum};
use ident::Intersample;
use study::scenario::ParametrizationSetting;

/// Parses `zoh` or `bandlimited`, listing both in `--help`.
fn intersample_parser() -> impl TypedValueParser<Value = Intersample> {
    PossibleValuesParser::new(Intersample::ALL.map(Intersample::name))
        .map(|s| s.parse().expect("a possible value"))
}

/// Parses `full` or `shear-frame`, listing both in `--help`.
fn parametrization_parser() -> impl TypedValueParser<Value = ParametrizationSetting> {
    PossibleValuesParser::new(ParametrizationSetting::ALL.map(ParametrizationSetting::name))
        .map(|s| s.parse().expect("a possible value"))
}

/// Parses `time`, `frf` or `both`, listing them in `--help`.
fn route_parser() -> impl TypedValueParser<Value = study::scenario::RouteSetting> {
    PossibleValuesParser::new(
        study::scenario::RouteSetting::ALL.map(study::scenario::RouteSetting::name),
    )
    .map(|s| {
        study::scenario::RouteSetting::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .expect("a possible value")
    })
}

/// frameid: simulate hammer tests on shear frames, identify M, K and R from
/// records, and measure how well they are recovered.
#[derive(Debug, Parser)]
#[command(name = "frameid", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the default study (the default when no command is given).
    Study(StudyArgs),
    /// Simulate a hammer campaign of a scenario and write its records and truth.
    Simulate(SimulateArgs),
    /// Identify modal parameters and M, K, R from records, FRFs or a realization.
    Identify(IdentifyArgs),
    /// Estimate FRFs (H1, H2 or Hv) with coherence from hammer or shaker records and write them as UFF58 and CSV.
    Frf(FrfArgs),
    /// Monte Carlo sweep over noise levels: simulate, identify and score many campaigns.
    Sweep(SweepArgs),
    /// Join the directories of a sharded sweep into what one run gives.
    Merge(MergeArgs),
    /// Render the HTML accuracy report of one or more sweep directories.
    Report(ReportArgs),
    /// Compare two sweeps' medians and efficiencies within their Monte Carlo errors (exit 1 if any differs).
    Compare(CompareArgs),
}

/// Record file format written by `simulate`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RecordFormat {
    /// CSV: `time,force,acc1,...`
    Csv,
    /// Universal File Format dataset 58, ASCII
    Uff,
    /// Universal File Format dataset 58b, binary
    UffBinary,
}

impl RecordFormat {
    /// The record layout written.
    pub fn layout(self) -> records::Format {
        match self {
            RecordFormat::Csv => records::Format::Csv { delimiter: b',' },
            RecordFormat::Uff => records::Format::Uff58Ascii,
            RecordFormat::UffBinary => records::Format::Uff58Binary,
        }
    }
}

/// Acquisition model override for `simulate`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AcquisitionArg {
    /// Analyzer chain: band-limited records
    Analyzer,
    /// Force held per sample (zero-order hold)
    Held,
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Scenario file (TOML)
    pub scenario: PathBuf,
    /// Output directory (created if missing)
    #[arg(long)]
    pub out: PathBuf,
    /// Number of hits (overrides the scenario)
    #[arg(long)]
    pub hits: Option<usize>,
    /// Noise as a fraction of each channel's RMS (overrides the scenario)
    #[arg(long)]
    pub noise: Option<f64>,
    /// Random seed
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Record file format
    #[arg(long, value_enum, default_value_t = RecordFormat::Csv)]
    pub format: RecordFormat,
    /// Acquisition model (overrides the scenario)
    #[arg(long, value_enum)]
    pub acquisition: Option<AcquisitionArg>,
    /// Write even if the records would take more than 1 GiB on disk
    #[arg(long)]
    pub force: bool,
}

/// Which channels of the record files are forces and responses.
#[derive(Debug, Args)]
pub struct SelectArgs {
    /// Input channel(s), comma separated: a name (`force`), `node:dir` (UFF, e.g. `1:+X`), `id:TEXT` or `#k`
    #[arg(long, default_value = "force")]
    pub input: String,
    /// Output channels in DOF order, comma separated (default: every channel but the inputs, in file order)
    #[arg(long)]
    pub outputs: Option<String>,
    /// Sampling rate for records without a time column, Hz
    #[arg(long)]
    pub fs: Option<f64>,
}

#[derive(Debug, Args)]
pub struct IdentifyArgs {
    /// Record files, one per hit (CSV or UFF58), or FRF files (UFF58 function type 4, FRF CSV); detected from the content
    #[arg(
        required_unless_present = "realization",
        conflicts_with = "realization"
    )]
    pub files: Vec<PathBuf>,
    /// A discrete realization instead of records: JSON with `dt` (or `dt_s`), `A`, `B`, `C`, `D` (arrays of rows)
    #[arg(long)]
    pub realization: Option<PathBuf>,
    /// Channels and sampling
    #[command(flatten)]
    pub select: SelectArgs,
    /// Collocated force/accelerometer pair OUT:IN, zero-based indices among the outputs and inputs or channel names (default: first output with first input)
    #[arg(long)]
    pub collocated: Option<String>,
    /// Model order (state dimension; default: automatic)
    #[arg(long)]
    pub order: Option<usize>,
    /// OKID observer order (default: automatic, BIC)
    #[arg(long)]
    pub observer_order: Option<usize>,
    /// The model's modes, one frequency per output in Hz (e.g. 2.7,9.2): the structural modes nearest to them form M, K and R, the others are reported as out-of-model modes
    #[arg(long, conflicts_with = "band")]
    pub modes: Option<String>,
    /// Only structural modes inside LOW:HIGH Hz form the model (e.g. 1:12); with more inside than outputs the most nearly second-order subset is used
    #[arg(long)]
    pub band: Option<String>,
    /// Intersample assumption: `bandlimited` for analyzer records (impulse invariance), `zoh` for inputs held over each sample (the paper's assumption)
    #[arg(long, default_value_t = Intersample::Bandlimited, value_parser = intersample_parser())]
    pub intersample: Intersample,
    /// Write the result as JSON on standard output
    #[arg(long)]
    pub json: bool,
    /// What excites the records: `hammer`, `continuous` (a shaker: random, burst random, chirp, swept sine) or `auto` (judged per record from the force's crest factor; reported)
    #[arg(long, default_value = "auto")]
    pub excitation: records::quality::Excitation,
    /// Decimate records sampled far above the modes' band before identification: `auto` (the factor that keeps the highest mode of the records' FRFs below 0.4 of the new Nyquist frequency), `off`, or a factor N
    #[arg(long, default_value = "auto")]
    pub decimate: study::decimate::DecimationSetting,
    /// What the state is at the start of every record: `auto` (at rest unless continuous records show motion before the force starts, or a misfit that stands out at their start), `at-rest`, or `unknown` (OKID drops the first equations of every record)
    #[arg(long, default_value = "auto")]
    pub initial_state: study::analysis::InitialStateSetting,
    /// Refuse the campaign if any hit fails a quality check (double hit, clipping, long pulse, undecayed response, low SNR) or is inconsistent with the other hits (dead, copied or spiked channel, duplicate record, level, spectrum or residual against the joint model; without --strict such hits are dropped with a warning)
    #[arg(long, conflicts_with = "drop_bad_hits")]
    pub strict: bool,
    /// Identify without the hits that fail a quality check (and say which were dropped)
    #[arg(long)]
    pub drop_bad_hits: bool,
    /// Skip the error bars (jackknife over the hits: one extra identification per hit, at most 20)
    #[arg(long)]
    pub no_uncertainty: bool,
    /// Refine M, K and the damping matrix by maximum likelihood over all hits (records only), with standard errors
    #[arg(long, conflicts_with = "realization")]
    pub refine: bool,
    /// FRF files without units (headerless `freq; H1; H2; ...` CSV, CSV columns without `[unit]`): the quantity, values in SI
    #[arg(long, value_parser = ["accelerance", "mobility", "receptance"], help_heading = "FRF files")]
    pub frf_quantity: Option<String>,
    /// FRF files without units: the unit of the values, e.g. `g/N` or `(m/s^2)/N` (converted to SI)
    #[arg(long, help_heading = "FRF files")]
    pub frf_unit: Option<String>,
    /// Headerless FRF CSV: the force point, `NAME` or `NAME@NODE:DIR` (e.g. `force@2:+X`); several files may name different references
    #[arg(long, help_heading = "FRF files")]
    pub reference: Vec<String>,
    /// Headerless FRF CSV: the response points, one per FRF column, comma separated (`NAME` or `NAME@NODE:DIR`)
    #[arg(long, help_heading = "FRF files")]
    pub responses: Option<String>,
    /// FRFs measured with an exponential window exp(-t/tau) not stated in the file: its tau in seconds, whose damping is removed
    #[arg(long, value_name = "TAU_S", help_heading = "FRF files")]
    pub exponential_tau: Option<f64>,
    /// Known sensor masses in kg, one per output (DOF order) or one for all: the identified M is also given without them (each accelerometer's mass taken off its floor's diagonal entry)
    #[arg(long, value_delimiter = ',', value_name = "KG")]
    pub sensor_mass: Option<Vec<f64>>,
    /// Also write, for correlation with other tools, DIR/modes.uff (the model's modes as UFF dataset 55, with modal A from the identified M) and DIR/model_frf.uff (the identified model's accelerance as UFF58 on the measured frequency grid)
    #[arg(long, conflicts_with = "realization", value_name = "DIR")]
    pub export: Option<PathBuf>,
    /// Also write an HTML page of the identification: data and preprocessing, warnings, hit quality, stabilization diagram, modes in and out of the model, identified values with error bars, measured FRFs and coherence against the identified model
    #[arg(long, conflicts_with = "realization", value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Parameters of the refinement: symmetric M, K, damping (`full`) or one mass per floor and one spring and dashpot per storey plus ground dashpots (`shear-frame`)
    #[arg(long, default_value_t = ParametrizationSetting::Full, value_parser = parametrization_parser(), requires = "refine")]
    pub parametrization: ParametrizationSetting,
}

/// FRF estimator of `frameid frf`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EstimatorArg {
    /// Gyx Gxx^-1: noise on the responses
    H1,
    /// Gyy Gxy^-1: noise on the force
    H2,
    /// Total least squares: noise on both
    Hv,
}

/// How `frameid frf` forms its averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AveragingArg {
    /// One block per hit for hammer records, Welch segments for continuous ones (as detected)
    Auto,
    /// One block per record (hammer hits)
    Hits,
    /// Welch segments (continuous records): Hann window, 50 % overlap
    Welch,
}

/// File layouts `frameid frf` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FrfFormatArg {
    /// `frf.uff`: UFF58 ASCII, function type 4 (FRFs) and 6 (coherence)
    Uff,
    /// `frf.uffb`: UFF58b binary, same datasets
    UffBinary,
    /// `frf.csv`: frequency_hz, re/im H(response/reference) and coh(...) columns
    Csv,
}

#[derive(Debug, Args)]
pub struct FrfArgs {
    /// Record files: hammer hits (averaged across hits) or shaker runs (Welch segments)
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Channels and sampling
    #[command(flatten)]
    pub select: SelectArgs,
    /// Output directory (created if missing): frf.uff and frf.csv by default
    #[arg(long)]
    pub out: PathBuf,
    /// Estimator: h1 (noise on the responses), h2 (noise on the force), hv (both)
    #[arg(long, value_enum, default_value_t = EstimatorArg::H1)]
    pub estimator: EstimatorArg,
    /// Averaging: across hits, Welch segments, or chosen from the detected excitation
    #[arg(long, value_enum, default_value_t = AveragingArg::Auto)]
    pub averaging: AveragingArg,
    /// Welch segment length, samples (default: a power of two giving at least 8 segments)
    #[arg(long)]
    pub segment: Option<usize>,
    /// Force window for hammer hits: the force is kept within S seconds of its peak, with cosine tapers of S seconds
    #[arg(long, value_name = "S")]
    pub force_window: Option<f64>,
    /// Exponential window for hammer hits, as the amplitude left at the end of the record (e.g. 0.01); the damping it adds is written with the FRFs and removed by `frameid identify`
    #[arg(long, value_name = "END")]
    pub exponential_window: Option<f64>,
    /// Keep only the lines inside LOW:HIGH Hz
    #[arg(long)]
    pub band: Option<String>,
    /// Collocated force/accelerometer pair OUT:IN (zero-based or names; default 0:0): the force is written at that accelerometer's node
    #[arg(long)]
    pub collocated: Option<String>,
    /// Layouts written (comma separated)
    #[arg(long, value_enum, value_delimiter = ',', default_value = "uff,csv")]
    pub format: Vec<FrfFormatArg>,
    /// What excites the records (`auto`, `hammer`, `continuous`)
    #[arg(long, default_value = "auto")]
    pub excitation: records::quality::Excitation,
    /// Refuse the campaign if any record fails a check or is inconsistent with the others (default: drop it with a warning)
    #[arg(long)]
    pub strict: bool,
    /// Print what was done as JSON
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct StudyArgs {
    /// Output folder (sweeps of each scenario and report.html)
    #[arg(long, default_value = "frameid-study")]
    pub out: PathBuf,
    /// Trials per noise level (default 50)
    #[arg(long)]
    pub trials: Option<usize>,
    /// Worker threads (default: all cores)
    #[arg(long)]
    pub threads: Option<usize>,
}

impl Default for StudyArgs {
    /// What `frameid` with no arguments runs.
    fn default() -> Self {
        StudyArgs {
            out: PathBuf::from("frameid-study"),
            trials: None,
            threads: None,
        }
    }
}

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Sweep directories (each with summary.json), one study each
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// The HTML file to write
    #[arg(long)]
    pub out: PathBuf,
    /// Report title
    #[arg(long, default_value = "frameid accuracy report")]
    pub title: String,
}

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Scenario file (TOML); its `[sweep]` table gives the defaults
    pub scenario: PathBuf,
    /// Output directory: trials.csv, summary.json, sweep.json
    #[arg(long)]
    pub out: PathBuf,
    /// Noise levels, comma separated fractions of each channel's RMS (e.g. 0,0.01,0.05)
    #[arg(long, value_delimiter = ',')]
    pub noise: Option<Vec<f64>>,
    /// Trials per noise level (and axis value)
    #[arg(long)]
    pub trials: Option<usize>,
    /// Base seed
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores); results do not depend on it
    #[arg(long)]
    pub threads: Option<usize>,
    /// Run only part K of N of the trials (e.g. 2/4); join the parts with `frameid merge`
    #[arg(long)]
    pub shard: Option<String>,
    /// Run even if `trials.csv` would take more than 1 GiB
    #[arg(long)]
    pub force: bool,
    /// Identification route (overrides the scenario's `identification.route`): `time` records, `frf` (H1 FRFs across the hits, pLSCF, LSFD, MKR) or `both` on the same campaigns
    #[arg(long, value_parser = route_parser())]
    pub route: Option<study::scenario::RouteSetting>,
}

#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The first sweep directory (complete or merged)
    pub first: PathBuf,
    /// The second sweep directory
    pub second: PathBuf,
    /// Differences above this many combined Monte Carlo standard errors count as changes
    #[arg(long, default_value_t = study::sweep::compare::DEFAULT_THRESHOLD)]
    pub threshold: f64,
    /// Scores to leave out, comma separated (e.g. refine_iterations, which a faster optimizer changes)
    #[arg(long, value_delimiter = ',')]
    pub ignore: Vec<String>,
    /// Write the comparison as JSON instead of text
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// Shard directories written by `frameid sweep --shard`
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Output directory
    #[arg(long)]
    pub out: PathBuf,
}
