"""dempath_diagnose: where a DEM model fails against measured markers, and which effect it misses.

Floor 4 of the house (docs/design.md): it uses dempath_sim (through the one adapter module
:mod:`dempath_diagnose.library.simulator`) and dempath_compare (loaders). See docs/diagnosis.md.
"""
