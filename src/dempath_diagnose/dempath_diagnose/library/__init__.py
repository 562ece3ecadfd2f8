"""The signature library: model passes of a scene and of each candidate effect, on shared seeds.

The lowest room of dempath_diagnose (above ``errors`` and ``records``): the one door to
dempath_sim (:mod:`.simulator`), which model particles stand for a marker
(:mod:`.counterparts`), the library on disk and its build (:mod:`.store`), Dask sweeps
(:mod:`.sweep`), packed libraries to ship (:mod:`.packed`) and hidden-effect cases written as
measurements (:mod:`.cases`). It imports no other room of the package.
"""
