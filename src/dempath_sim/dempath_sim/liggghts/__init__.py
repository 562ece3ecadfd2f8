"""LIGGGHTS 3.8 backend: write an input deck from a dempath scene, run it, read the dumps back.

Modules: ``install`` (find / apt-install LIGGGHTS), ``runner`` (run a deck, one-line errors),
``commands`` (deck building blocks shared by scenes and validation cases), ``deck`` (scene ->
deck), ``dumps`` (dump and force files -> arrays), ``backend`` (scene -> SimResult).
"""
