"""Type stubs of the frameid package (the classes and functions are in the
native module frameid._native; see their docstrings)."""

import os
import pathlib
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

__version__: str

_Path = str | os.PathLike[str]
_F64 = npt.NDArray[np.float64]
_C128 = npt.NDArray[np.complex128]
_Pick = int | str

class Error(ValueError):
    """Bad input or a failed identification; the message is the command line's."""

class Campaign:
    """The hits of one test set-up (forces and accelerations every dt_s)."""

    def __init__(
        self,
        force: npt.ArrayLike,
        acc: npt.ArrayLike,
        dt_s: float,
        *,
        inputs: Sequence[str] | None = None,
        outputs: Sequence[str] | None = None,
        labels: Sequence[str] | None = None,
    ) -> None:
        """force: (hits, inputs, samples) in N; acc: (hits, outputs, samples)
        in m/s², one accelerometer per floor in floor order; finite samples."""

    @property
    def force(self) -> _F64:
        """(hits, inputs, samples), N."""

    @property
    def acc(self) -> _F64:
        """(hits, outputs, samples), m/s²."""

    @property
    def dt_s(self) -> float: ...
    @property
    def fs_hz(self) -> float: ...
    @property
    def inputs(self) -> list[str]: ...
    @property
    def outputs(self) -> list[str]: ...
    @property
    def labels(self) -> list[str]: ...
    @property
    def hits(self) -> int: ...
    @property
    def samples(self) -> int: ...
    def subset(self, indices: Sequence[int]) -> Campaign: ...
    def __len__(self) -> int: ...

class Mode:
    """One identified mode with its accuracy indicators."""

    @property
    def frequency_hz(self) -> float: ...
    @property
    def damping_ratio(self) -> float: ...
    @property
    def mode_shape(self) -> _C128:
        """One complex entry per output, largest component 1."""

    @property
    def pole(self) -> complex: ...
    @property
    def emac(self) -> float | None: ...
    @property
    def emac_output(self) -> float | None: ...
    @property
    def emac_input(self) -> float | None: ...
    @property
    def mpc(self) -> float: ...
    @property
    def msv(self) -> float: ...
    @property
    def cmi(self) -> float: ...
    @property
    def structural(self) -> bool: ...
    @property
    def used(self) -> bool:
        """Used by MKR and the Rayleigh fit."""

class Uncertainty:
    """Jackknife error bars over the hits (over 20 groups of hits above 20 hits): *_mean and *_std."""

    @property
    def method(self) -> str: ...
    @property
    def hits(self) -> int: ...
    @property
    def groups(self) -> int: ...
    @property
    def resamples(self) -> int: ...
    @property
    def failed(self) -> list[dict[str, str]]: ...
    @property
    def model_order(self) -> int: ...
    @property
    def observer_order(self) -> int | None: ...
    @property
    def frequencies_hz_mean(self) -> _F64: ...
    @property
    def frequencies_hz_std(self) -> _F64: ...
    @property
    def damping_ratios_mean(self) -> _F64: ...
    @property
    def damping_ratios_std(self) -> _F64: ...
    @property
    def rayleigh_alpha_mean(self) -> float: ...
    @property
    def rayleigh_alpha_std(self) -> float: ...
    @property
    def rayleigh_beta_mean(self) -> float: ...
    @property
    def rayleigh_beta_std(self) -> float: ...
    @property
    def mass_mean(self) -> _F64: ...
    @property
    def mass_std(self) -> _F64: ...
    @property
    def stiffness_mean(self) -> _F64: ...
    @property
    def stiffness_std(self) -> _F64: ...
    @property
    def damping_mkr_mean(self) -> _F64: ...
    @property
    def damping_mkr_std(self) -> _F64: ...
    @property
    def damping_rayleigh_mean(self) -> _F64: ...
    @property
    def damping_rayleigh_std(self) -> _F64: ...
    def to_dict(self) -> dict[str, Any]:
        """The `uncertainty` of `frameid identify --json`."""

class RefinedMode:
    @property
    def frequency_hz(self) -> float: ...
    @property
    def frequency_std_hz(self) -> float: ...
    @property
    def damping_ratio(self) -> float: ...
    @property
    def damping_ratio_std(self) -> float: ...
    @property
    def mode_shape(self) -> _C128: ...
    @property
    def mode_shape_std(self) -> _C128:
        """Standard deviations of the real and imaginary parts."""

    @property
    def pole(self) -> complex: ...

class Refined:
    """Maximum-likelihood M, K and damping with standard errors (*_std)."""

    @property
    def mass(self) -> _F64: ...
    @property
    def stiffness(self) -> _F64: ...
    @property
    def damping(self) -> _F64: ...
    @property
    def mass_std(self) -> _F64: ...
    @property
    def stiffness_std(self) -> _F64: ...
    @property
    def damping_std(self) -> _F64: ...
    @property
    def modes(self) -> list[RefinedMode]: ...
    @property
    def noise_outputs(self) -> _F64: ...
    @property
    def noise_inputs(self) -> _F64: ...
    @property
    def iterations(self) -> int: ...
    @property
    def stop(self) -> str:
        """Gradient, Step, Cost, MaxIterations or NoProgress."""

    @property
    def converged(self) -> bool: ...
    @property
    def initial_cost(self) -> float: ...
    @property
    def cost(self) -> float: ...
    @property
    def parameter_labels(self) -> list[str]: ...
    @property
    def parameters(self) -> _F64: ...
    @property
    def covariance(self) -> _F64: ...

class Identification:
    """Modal parameters, M, K and damping, with the diagnostics of
    `frameid identify --json`."""

    @property
    def mass(self) -> _F64: ...
    @property
    def stiffness(self) -> _F64: ...
    @property
    def damping_mkr(self) -> _F64: ...
    @property
    def damping_rayleigh(self) -> _F64: ...
    @property
    def modes(self) -> list[Mode]:
        """Every oscillatory mode, ascending frequency (see Mode.used)."""

    @property
    def used_modes(self) -> list[int]: ...
    @property
    def frequencies_hz(self) -> _F64:
        """Of the modes used."""

    @property
    def damping_ratios(self) -> _F64: ...
    @property
    def mode_shapes(self) -> _C128:
        """Outputs × modes used."""

    @property
    def rayleigh_alpha(self) -> float: ...
    @property
    def rayleigh_beta(self) -> float: ...
    @property
    def consistency(self) -> float: ...
    @property
    def model_order(self) -> int: ...
    @property
    def intersample(self) -> str: ...
    @property
    def polarity_flipped(self) -> bool: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def hit_quality(self) -> list[dict[str, Any]]: ...
    @property
    def decimation(self) -> dict[str, Any] | None:
        """The decimation before identification; None at the records' own rate."""

    @property
    def initial_state(self) -> dict[str, Any] | None:
        """The initial state assumed and why; None when nothing was judged."""

    @property
    def inconsistent_hits(self) -> list[dict[str, Any]]:
        """Hits inconsistent with the others: record, file, channel, kind, message."""

    @property
    def consistency_notes(self) -> list[str]: ...
    @property
    def dropped_hits(self) -> list[str]: ...
    @property
    def mode_selection(self) -> str: ...
    @property
    def out_of_model_modes(self) -> list[int]: ...
    @property
    def uncertainty(self) -> Uncertainty | None: ...
    @property
    def uncertainty_skipped(self) -> str | None: ...
    @property
    def refined(self) -> Refined | None: ...
    @property
    def hankel_singular_values(self) -> _F64: ...
    @property
    def observer(self) -> dict[str, Any] | None: ...
    @property
    def realization(self) -> dict[str, Any]:
        """a, b, c, d (arrays) and dt_s."""

    @property
    def files(self) -> list[str]: ...
    @property
    def from_realization(self) -> bool: ...
    @property
    def dt_s(self) -> float: ...
    @property
    def hits(self) -> int: ...
    @property
    def samples(self) -> int: ...
    @property
    def inputs(self) -> list[str]: ...
    @property
    def outputs(self) -> list[str]: ...
    @property
    def collocated(self) -> tuple[int, int]: ...

_Point = str | tuple[str, int, int | str]

class FrfSet:
    """FRFs: values[k, i, j] is response i over reference j at frequency_hz[k], SI."""

    def __init__(
        self,
        frequency_hz: npt.ArrayLike,
        values: npt.ArrayLike,
        *,
        quantity: str = "accelerance",
        coherence: npt.ArrayLike | None = None,
        averages: int | None = None,
        responses: str | Sequence[_Point] | None = None,
        references: str | Sequence[_Point] | None = None,
        collocated: tuple[_Pick, _Pick] | str | Sequence[tuple[_Pick, _Pick] | str] | None = None,
        exponential_tau_s: float | None = None,
    ) -> None:
        """frequency_hz (lines,); values complex (lines, outputs, references);
        coherence real, same shape; points 'name' or 'name@node:dir' or
        (name, node, direction)."""

    @property
    def frequency_hz(self) -> _F64: ...
    @property
    def values(self) -> _C128:
        """(lines, outputs, references), SI unit of `quantity`."""

    @property
    def coherence(self) -> _F64 | None:
        """(lines, outputs, references) or None."""

    @property
    def quantity(self) -> str:
        """accelerance, mobility or receptance."""

    @property
    def unit(self) -> str: ...
    @property
    def averages(self) -> int | None: ...
    @property
    def exponential_tau_s(self) -> float | None: ...
    @property
    def outputs(self) -> list[str]: ...
    @property
    def references(self) -> list[str]: ...
    @property
    def response_points(self) -> list[dict[str, Any]]:
        """name, node, direction (None where unknown)."""

    @property
    def reference_points(self) -> list[dict[str, Any]]: ...
    @property
    def collocated(self) -> list[tuple[int, int]]:
        """Detected or given (output, reference) pairs, zero-based."""

    @property
    def files(self) -> list[str]: ...
    @property
    def lines(self) -> int: ...
    def write(self, path: _Path, format: str = "uff") -> pathlib.Path:
        """uff, uff-binary, csv or csv-complex."""

    def __len__(self) -> int: ...

class FrfResult(FrfSet):
    """FRFs estimated from a campaign, with what `frameid frf` reports."""

    @property
    def estimator(self) -> str: ...
    @property
    def excitation(self) -> str:
        """hammer or continuous."""

    @property
    def hits_used(self) -> int: ...
    @property
    def dropped(self) -> list[str]: ...
    @property
    def block_len(self) -> int: ...
    @property
    def resolution_hz(self) -> float: ...
    @property
    def model_checks(self) -> bool: ...
    @property
    def windows(self) -> dict[str, Any]: ...
    @property
    def hit_quality(self) -> list[dict[str, Any]]: ...
    @property
    def warnings(self) -> list[str]: ...

class FrfRefined:
    """Maximum-likelihood M, K and damping on the FRFs, with standard errors."""

    @property
    def mass(self) -> _F64: ...
    @property
    def stiffness(self) -> _F64: ...
    @property
    def damping(self) -> _F64: ...
    @property
    def mass_std(self) -> _F64: ...
    @property
    def stiffness_std(self) -> _F64: ...
    @property
    def damping_std(self) -> _F64: ...
    @property
    def modes(self) -> list[RefinedMode]: ...
    @property
    def noise_model(self) -> str: ...
    @property
    def reference_dofs(self) -> list[int]: ...
    @property
    def iterations(self) -> int: ...
    @property
    def stop(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def initial_cost(self) -> float: ...
    @property
    def cost(self) -> float: ...
    @property
    def observations(self) -> int: ...
    @property
    def unknowns(self) -> int: ...
    @property
    def band_hz(self) -> tuple[float, float]: ...
    @property
    def lines(self) -> int: ...
    @property
    def parameter_labels(self) -> list[str]: ...
    @property
    def parameters(self) -> _F64: ...
    @property
    def covariance(self) -> _F64: ...

class FrfUncertainty:
    """Error bars of an FRF identification by the parametric bootstrap (*_std)."""

    @property
    def method(self) -> str: ...
    @property
    def resamples(self) -> int: ...
    @property
    def failed(self) -> int: ...
    @property
    def frequencies_hz_std(self) -> _F64: ...
    @property
    def damping_ratios_std(self) -> _F64: ...
    @property
    def mass_std(self) -> _F64: ...
    @property
    def stiffness_std(self) -> _F64: ...
    @property
    def damping_mkr_std(self) -> _F64: ...
    @property
    def damping_rayleigh_std(self) -> _F64: ...
    def to_dict(self) -> dict[str, Any]:
        """The `uncertainty` of `frameid identify --json` on FRF files."""

class FrfIdentification:
    """Modes, M, K and damping from FRFs, with the checks and the diagram."""

    @property
    def mass(self) -> _F64: ...
    @property
    def stiffness(self) -> _F64: ...
    @property
    def damping_mkr(self) -> _F64: ...
    @property
    def damping_rayleigh(self) -> _F64: ...
    @property
    def modes(self) -> list[Mode]: ...
    @property
    def used_modes(self) -> list[int]: ...
    @property
    def out_of_model_modes(self) -> list[int]: ...
    @property
    def frequencies_hz(self) -> _F64: ...
    @property
    def damping_ratios(self) -> _F64: ...
    @property
    def mode_shapes(self) -> _C128:
        """Outputs × modes used."""

    @property
    def rayleigh_alpha(self) -> float: ...
    @property
    def rayleigh_beta(self) -> float: ...
    @property
    def consistency(self) -> float: ...
    @property
    def polarity_flipped(self) -> bool: ...
    @property
    def model_order(self) -> int:
        """The pLSCF order used."""

    @property
    def exponential_tau_s(self) -> float | None: ...
    @property
    def quantity(self) -> str: ...
    @property
    def stabilization(self) -> dict[str, Any]:
        """order, frequency_hz, damping_ratio (arrays), status (list), physical (array)."""

    @property
    def rejected_modes(self) -> list[dict[str, Any]]: ...
    @property
    def checks(self) -> dict[str, list[dict[str, Any]]]:
        """coherence and reciprocity, as `checks` of `frameid identify --json`."""

    @property
    def warnings(self) -> list[str]: ...
    @property
    def uncertainty(self) -> FrfUncertainty | None: ...
    @property
    def uncertainty_skipped(self) -> str | None: ...
    @property
    def refined(self) -> FrfRefined | None: ...
    @property
    def files(self) -> list[str]: ...
    @property
    def outputs(self) -> list[str]: ...
    @property
    def references(self) -> list[str]: ...
    @property
    def collocated(self) -> tuple[int, int]: ...
    @property
    def lines(self) -> int: ...
    @property
    def band_hz(self) -> tuple[float, float]: ...
    def write_modes(self, path: _Path) -> pathlib.Path:
        """UFF55 of the modes used (modes.uff of --export)."""

    def model_frf(self, frequency_hz: npt.ArrayLike) -> FrfSet:
        """The model's accelerance for each placed reference (model_frf.uff of --export)."""

class Truth:
    """Known truth of a simulated campaign (truth.json)."""

    @property
    def mass(self) -> _F64: ...
    @property
    def bare_mass(self) -> _F64: ...
    @property
    def sensor_masses_kg(self) -> _F64: ...
    @property
    def stiffness(self) -> _F64: ...
    @property
    def damping(self) -> _F64: ...
    @property
    def frequencies_hz(self) -> _F64: ...
    @property
    def damping_ratios(self) -> _F64: ...
    @property
    def mode_shapes(self) -> _C128:
        """Floors × modes."""

    @property
    def dt_s(self) -> float: ...
    @property
    def hit_floor(self) -> int:
        """1-based."""

    @property
    def dofs(self) -> int: ...
    @property
    def seed(self) -> int: ...
    @property
    def scenario(self) -> str: ...
    @property
    def hits(self) -> list[dict[str, Any]]: ...
    @property
    def settings(self) -> dict[str, Any]: ...
    def to_json(self) -> str: ...

class Bound:
    """Cramér–Rao bound as relative standard deviations."""

    @property
    def frequencies(self) -> _F64: ...
    @property
    def damping_ratios(self) -> _F64: ...
    @property
    def mass(self) -> float: ...
    @property
    def stiffness(self) -> float: ...
    @property
    def damping(self) -> float: ...
    @property
    def noise(self) -> float: ...
    @property
    def seed(self) -> int: ...
    def to_dict(self) -> dict[str, Any]: ...

class Sweep:
    """Trials of a sweep (or shard) with their scores and, whole, the summary."""

    @property
    def scenario(self) -> str: ...
    @property
    def scenario_path(self) -> str: ...
    @property
    def noise_levels(self) -> list[float]: ...
    @property
    def trials(self) -> int: ...
    @property
    def seed(self) -> int: ...
    @property
    def shard(self) -> tuple[int, int] | None: ...
    @property
    def complete(self) -> bool: ...
    @property
    def plan(self) -> dict[str, Any]: ...
    @property
    def score_names(self) -> list[str]: ...
    @property
    def scores(self) -> _F64:
        """Trials × score_names, NaN for failed trials."""

    def column(self, name: str) -> _F64: ...
    @property
    def noise(self) -> _F64: ...
    @property
    def trial(self) -> list[int]: ...
    @property
    def axis(self) -> list[str]: ...
    @property
    def seeds(self) -> list[int]: ...
    @property
    def status(self) -> list[str]: ...
    @property
    def reason(self) -> list[str]: ...
    @property
    def message(self) -> list[str]: ...
    @property
    def summary(self) -> dict[str, Any] | None: ...
    def summary_json(self) -> str | None: ...
    def trials_csv(self) -> str: ...
    def manifest_json(self) -> str: ...
    @property
    def path(self) -> str | None: ...
    @property
    def warnings(self) -> list[str]: ...
    def write(self, out: _Path) -> Sweep: ...
    def __len__(self) -> int: ...

def read_records(
    paths: _Path | Sequence[_Path],
    input: str | Sequence[str] | None = "force",
    outputs: str | Sequence[str] | None = None,
    *,
    fs: float | None = None,
) -> Campaign:
    """Record files (CSV, UFF58), one per hit, channels selected as the CLI does."""

def identify(
    campaign: Campaign,
    collocated: tuple[_Pick, _Pick] | Sequence[_Pick] | str | None = None,
    *,
    order: int | None = None,
    observer_order: int | None = None,
    intersample: str = "bandlimited",
    strict: bool = False,
    drop_bad_hits: bool = False,
    uncertainty: bool = True,
    refine: bool = False,
    parametrization: str = "full",
    excitation: str = "auto",
    modes: Sequence[float] | None = None,
    band: tuple[float, float] | None = None,
    decimate: str | int = "auto",
    initial_state: str = "auto",
) -> Identification:
    """What `frameid identify` runs, with the same defaults."""

def identify_realization(
    path: _Path,
    collocated: tuple[_Pick, _Pick] | Sequence[_Pick] | str | None = None,
    *,
    order: int | None = None,
    intersample: str = "bandlimited",
) -> Identification:
    """`frameid identify --realization FILE`."""

def frf(
    campaign: Campaign,
    *,
    estimator: str = "H1",
    averaging: str = "auto",
    segment: int | None = None,
    force_window_s: float | None = None,
    exponential_end: float | None = None,
    band_hz: tuple[float, float] | None = None,
    strict: bool = False,
    collocated: tuple[_Pick, _Pick] | Sequence[_Pick] | str | None = None,
    excitation: str = "auto",
) -> FrfResult:
    """`frameid frf`: screened FRFs of a campaign with coherence."""

def read_frf(
    paths: _Path | Sequence[_Path],
    *,
    quantity: str | None = None,
    unit: str | None = None,
    reference: _Point | Sequence[_Point] | None = None,
    responses: str | Sequence[_Point] | None = None,
) -> FrfSet:
    """FRF files (UFF58, CSV) collated as `frameid identify FILES` does."""

def identify_frf(
    frfs: FrfSet,
    *,
    band_hz: tuple[float, float] | None = None,
    order: int | None = None,
    modes: Sequence[float] | None = None,
    collocated: tuple[_Pick, _Pick] | Sequence[_Pick] | str | None = None,
    exponential_tau_s: float | None = None,
    uncertainty: bool = True,
    refine: bool = False,
    parametrization: str = "full",
    strict: bool = False,
) -> FrfIdentification:
    """`frameid identify` on FRF files: checks, pLSCF, LSFD, MKR, Rayleigh (and refinement)."""

def simulate(
    scenario: _Path,
    *,
    hits: int | None = None,
    noise: float | None = None,
    seed: int = 1,
    acquisition: str | None = None,
    out: _Path | None = None,
    format: str = "csv",
    force: bool = False,
) -> tuple[Campaign, Truth]:
    """`frameid simulate`: a campaign with its truth (and files with out=)."""

def bound(scenario: _Path, noise: float, *, seed: int = 1, hits: int | None = None) -> Bound:
    """The Cramér–Rao bound a sweep with this seed reports at this noise level."""

def sweep(
    scenario: _Path,
    *,
    noise: float | Sequence[float] | npt.ArrayLike | None = None,
    trials: int | None = None,
    seed: int | None = None,
    shard: tuple[int, int] | str | None = None,
    threads: int | None = None,
    out: _Path | None = None,
    force: bool = False,
) -> Sweep:
    """`frameid sweep` in memory, or into out=."""

def merge(parts: Sequence[Sweep | _Path], *, out: _Path | None = None) -> Sweep:
    """`frameid merge` of Sweep objects or shard directories."""

def compare(
    first: Sweep | _Path,
    second: Sweep | _Path,
    *,
    threshold: float = 4.0,
    ignore: Sequence[str] = (),
) -> dict[str, Any]:
    """`frameid compare --json`: medians and efficiencies of two complete sweeps in units of
    their combined Monte Carlo standard errors; ``changed`` lists those beyond ``threshold``."""

def report(sweeps: Sequence[Sweep | _Path], out: _Path, *, title: str = "frameid accuracy report") -> str:
    """`frameid report`: the HTML report of sweep directories."""

def set_keep_awake(on: bool) -> None:
    """Turn on or off (for the process) the second thread kept awake, spinning between
    pieces of work, while an identification, refinement or bound runs; on by default. Off,
    the calls take longer and give the same numbers."""

def keep_awake() -> bool:
    """Whether a second thread is kept awake while a call runs (:func:`set_keep_awake`)."""
