"""The diagnosis itself: a measured pass against the library, to a verdict and where it fails.

Reading a measured pass (:mod:`.measure`), its group statistics (:mod:`.statistics`), the
emulator of the library (:mod:`.emulator`), the model probabilities and the verdict
(:mod:`.verdict`), one diagnosis (:mod:`.diagnosis`), its streaming form for the node
(:mod:`.live`), the paper's Table 7 of a band (:mod:`.bandtracks`) and the check that fitted
strengths' uncertainties are calibrated (:mod:`.coverage`). Imports the ``library`` room only.
"""
