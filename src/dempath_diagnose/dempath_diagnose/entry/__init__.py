"""Typed entry points below the commands: a frozen request in, a frozen outcome out.

``dempath diagnose`` and ``dempath recalibrate`` only parse their arguments into a
:class:`~.diagnosis.DiagnoseRequest` or :class:`~.recalibration.RecalibrationRequest`, call
:func:`~.diagnosis.run_diagnosis` or :func:`~.recalibration.run_recalibration` and print the
outcome; the demo (dempath_bringup) calls the same functions and passes the outcomes between its
stages. Above every room of the package: it joins the library, the decision, the recalibration
and the report.
"""
