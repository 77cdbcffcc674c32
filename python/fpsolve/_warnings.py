"""The warnings fpsolve raises: a result computed but not vouched for as it stands."""


class FpsolveWarning(UserWarning):
    """A result fpsolve computed but does not vouch for as it stands (the Python face of the
    command line's exit status 1): read its message, and the result's ``flags``."""


class MonteCarloWarning(FpsolveWarning):
    """A Monte Carlo run whose verdict failed (too many trajectories blew up, or the run is not
    stationary) or whose summary holds numbers without a finite value (NaN in the arrays)."""
