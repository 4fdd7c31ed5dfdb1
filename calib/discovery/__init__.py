"""The discrepancy search (docs/discrepancy.md): where the seed's model disagrees with a session,
which physical effect explains it, and whether the data can tell.

- :mod:`~calib.discovery.effects`: the library of candidate effects (design columns, simulator fields).
- :mod:`~calib.discovery.problem`: the generalised least-squares problem over all steps, nested tests.
- :mod:`~calib.discovery.observe`: which candidates a session can observe at all.
- :mod:`~calib.discovery.nuisance`: lack of fit that no named effect explains.
- :mod:`~calib.discovery.report`: where the residual sits, and the summary lines.
- :mod:`~calib.discovery.search`: the forward search itself (``discover``) and its verdict.
"""
