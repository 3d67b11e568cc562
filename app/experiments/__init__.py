"""Experiments on the simulated rig, behind `mirrorscan experiment NAME`.

The paper's figures 4a and 5a (paper.py: angle, distance), the hinged mirrors' angle with the views
through several mirrors (kaleidoscope.py), and temporal smoothing on the walking figure
(temporal.py); and, run as a module, where the refinement's plane errors come from (refine_bias.py).
"""
