"""CalculiX decks, runs and result parsing; the FEA-to-compliance job."""

from .ccx import CcxError, parse_dat, run_ccx, write_matrix_deck, write_static_deck
from .config import ConfigError, LinkJob, load_link, parse_link
from .job import LinkResult, auto_amplitudes, beam_estimate, run_link

__all__ = [
    "CcxError",
    "ConfigError",
    "LinkJob",
    "LinkResult",
    "load_link",
    "parse_link",
    "run_link",
    "parse_dat",
    "run_ccx",
    "write_static_deck",
    "write_matrix_deck",
    "auto_amplitudes",
    "beam_estimate",
]
