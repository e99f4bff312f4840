"""Case files: the TOML format (:mod:`.schema`), its loader (:mod:`.load`), the formulas
(:mod:`.formula`)."""
from xfemcontact.case.load import Case, load_case

__all__ = ["Case", "load_case"]
