"""The headline error: the measured markers scored against the model's distribution, and the
floors it is judged by, computed like for like (issue 26).

- :mod:`.samples`: which markers a figure sees and when (``MarkerSamples``), and a model run
  playing the measurement with exactly those samples;
- :mod:`.score`: the energy score of each measured trajectory against the model's cube
  candidates over packing seeds (``headline_error``);
- :mod:`.ensemble`: a model at any strength of a candidate from the library's paired runs;
- :mod:`.floor`: the floor band of a figure, the model played as the measurement (leave one
  seed out) with the same markers, samples, noise and candidate pools;
- :mod:`.fall`: one hidden-effect case from the library's own runs: before, the true and the
  best wrong fit after, each beside its floor; held-out markers; Table 7 like for like.
"""
