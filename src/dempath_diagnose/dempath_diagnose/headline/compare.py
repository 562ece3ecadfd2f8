"""Two fitted models against one measurement: does the measurement prefer the other one?

A fitted model's headline error inside its own floor band says the measurement is a plausible
draw of that model; it does not say the model is the right one. A model whose distribution is
wide has a wide floor band, and a rival candidate fitted as well as it can may land inside its
own band while the measurement clearly prefers another model. The energy score is proper: in
expectation the true model scores lowest, so two models are compared by their scores on the
same markers, paired marker by marker (the comparison of forecasts by their score differences,
Diebold & Mariano 1995, J. Bus. Econ. Stat. 13:253): one-sided t test of the mean per-marker
difference over the markers both scored. A fitted model counts as *at its floor* only when its
headline lies at or below its floor band and no rival fitted with the same budget scores
significantly lower (5 %).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dempath_diagnose.records import F64

LEVEL = 0.05  # one-sided significance of "the rival scores lower"
MIN_MARKERS = 3  # markers both models scored, for a test


def rival_lower(this: F64, rival: F64, level: float = LEVEL) -> dict[str, Any]:
    """Whether ``rival`` scores significantly lower than ``this``, per marker (m,) each [m].

    Returns:
        {'lower': bool, 'p': one-sided p value or None, 'markers': markers compared,
        'mean_difference_mm': mean of this - rival [mm]}.
    """
    from scipy import stats

    both = np.isfinite(this) & np.isfinite(rival)
    d = np.asarray(this, np.float64)[both] - np.asarray(rival, np.float64)[both]
    if len(d) < MIN_MARKERS:
        return {'lower': False, 'p': None, 'markers': len(d), 'mean_difference_mm': None}
    if np.allclose(d, d[0]):
        p = 0.0 if d[0] > 0 else 1.0
    else:
        p = float(stats.ttest_1samp(d, 0.0, alternative='greater').pvalue)
    return {'lower': bool(p < level), 'p': p, 'markers': len(d),
            'mean_difference_mm': float(d.mean() * 1e3)}
