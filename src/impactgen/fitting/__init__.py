"""Fitting a contact law's parameters to measured impacts (`impactgen fit`, `impactgen.fit`).

`data` reads and checks the measured impacts and the fitted keys, `solve` runs the least
squares with the compiled model and gives the errors, `report` prints and draws the result.
"""
from .solve import FitResult, LawFit, fit

__all__ = ["fit", "FitResult", "LawFit"]
