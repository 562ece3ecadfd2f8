"""What a diagnosis and a recalibration write: JSON, markdown, xlsx and figures.

``diagnosis_*`` for ``dempath diagnose`` (:mod:`.diagnosis_outputs`, :mod:`.diagnosis_plots`),
``recalibration_*`` for ``dempath recalibrate`` (:mod:`.recalibration_outputs`,
:mod:`.recalibration_figures`, :mod:`.recalibration_paper`). The top room: it may import every
other room and none imports it.
"""
