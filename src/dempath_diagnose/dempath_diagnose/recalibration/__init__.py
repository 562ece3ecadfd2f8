"""The recalibration: switch on the diagnosed effect, fit its strength, confirm with real runs.

The objective and its floor (:mod:`.objective`), the search on the emulator (:mod:`.search`),
the loop (:mod:`.loop`), which candidates are fitted (:mod:`.targets`), the real evaluations
(:mod:`.evaluations`), its progress records (:mod:`.progress`) and the paper's metrics before
and after (:mod:`.paper_metrics`). Imports the ``library`` and ``decision`` rooms.
"""
