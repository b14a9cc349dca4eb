"""frameid: identify the mass, stiffness and damping matrices of shear frames
from impact-hammer tests, simulate campaigns with known truth, and measure by
Monte Carlo sweeps how well a set-up and a noise level let you recover them.

The functions call the Rust libraries behind the ``frameid`` command line
directly; numpy arrays go in and come out, the long computations release the
interpreter, every result pickles, and every error raises :class:`Error` (a
``ValueError``) with the message the command line prints.

>>> import frameid
>>> camp, truth = frameid.simulate("scenarios/paper-case1.toml", hits=10, noise=0.01, seed=1)
>>> res = frameid.identify(camp, collocated=(truth.hit_floor - 1, 0))
>>> res.mass, res.stiffness, res.damping_mkr, res.damping_rayleigh    # numpy arrays
>>> res.modes[0].frequency_hz, res.uncertainty.mass_std
>>> frameid.identify(camp, refine=True).refined.damping_std
>>> frfs = frameid.frf(camp, exponential_end=0.01)                     # FRFs with coherence
>>> frameid.identify_frf(frfs).mass, frfs.write("frf.uff")

Functions: :func:`read_records`, :func:`identify`, :func:`identify_realization`,
:func:`simulate`, :func:`bound`, :func:`sweep`, :func:`merge`, :func:`compare`, :func:`report`;
the FRF route: :func:`frf`, :func:`read_frf`, :func:`identify_frf`; threads:
:func:`set_keep_awake`, :func:`keep_awake`.
Classes: :class:`Campaign`, :class:`Identification` (with :class:`Mode`,
:class:`Uncertainty`, :class:`Refined`, :class:`RefinedMode`), :class:`Truth`,
:class:`Bound`, :class:`Sweep`; :class:`FrfSet` (and :class:`FrfResult`),
:class:`FrfIdentification` (with :class:`FrfUncertainty`, :class:`FrfRefined`).
"""

from ._native import (
    Bound,
    Campaign,
    Error,
    FrfIdentification,
    FrfRefined,
    FrfResult,
    FrfSet,
    FrfUncertainty,
    Identification,
    Mode,
    Refined,
    RefinedMode,
    Sweep,
    Truth,
    Uncertainty,
    __version__,
    bound,
    compare,
    frf,
    identify,
    identify_frf,
    identify_realization,
    keep_awake,
    merge,
    read_frf,
    read_records,
    report,
    set_keep_awake,
    simulate,
    sweep,
)

__all__ = [
    "Bound",
    "Campaign",
    "Error",
    "FrfIdentification",
    "FrfRefined",
    "FrfResult",
    "FrfSet",
    "FrfUncertainty",
    "Identification",
    "Mode",
    "Refined",
    "RefinedMode",
    "Sweep",
    "Truth",
    "Uncertainty",
    "__version__",
    "bound",
    "compare",
    "frf",
    "identify",
    "identify_frf",
    "identify_realization",
    "keep_awake",
    "merge",
    "read_frf",
    "read_records",
    "report",
    "set_keep_awake",
    "simulate",
    "sweep",
]
