"""Physics validation cases shared by the tests and the ``dempath validate`` report.

Each case has an analytic (or semi-analytic) reference and runs on the dempath engine and, where
LIGGGHTS is installed, on LIGGGHTS through the same material records: two-sphere normal impact
(``impact``), a sphere on an incline (``incline``), energy conservation in a closed box
(``energy_conservation``), the angle of repose of a lifted-cylinder discharge (``repose``) and the
cross-engine comparison on a reduced tillage scene (``cross_engine``). The cases share their
set-up (materials, parameters, one run per engine) through ``cases``.
"""

from __future__ import annotations

CASES = ('impact', 'incline', 'energy', 'repose')  # the report's cases, in order
