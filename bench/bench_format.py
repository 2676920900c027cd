"""Number formatting shared by the benchmark reports (bench/report.sh, bench/atlas_peer.sh)."""
from math import floor, log10


def fmt(x, digits=3):
    """x to `digits` significant digits; "n/a" for None."""
    if x is None:
        return "n/a"
    if x == 0:
        return "0"
    d = max(0, digits - 1 - int(floor(log10(abs(x)))))
    return f"{x:.{d}f}"
