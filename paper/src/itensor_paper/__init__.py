"""The paper's experiments reproduced with interaction-tensor.

- :mod:`.judge`: an automatic model of people's verdicts on a pose, per affordance
- :mod:`.labelled` (+ ``data/``): the labelled poses the judge is checked on
- :mod:`.rooms`: procedural validation rooms (furniture with labelled places)
- :mod:`.oracle`: exhaustive searches of a scene's valid poses
- :mod:`.tuning`: each affordance's acceptance, chosen on the validation rooms
- :mod:`.baselines`: the paper's Naive and Bisector-surface (ICP) baselines
- :mod:`.runner`, :mod:`.merge`, :mod:`.report`, :mod:`.pictures`: Table 1's protocol, runs
  split and merged, its tables and pictures; :mod:`.summary`: the tracked summary
- :mod:`.cli`: ``itensor paper ...``
"""
