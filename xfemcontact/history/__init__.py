"""Load histories: instants, loads at an instant, load steps, checkpoints.

* :mod:`~xfemcontact.history.loading`: the case's loads at any instant (imposed
  values, their lift, tractions and body forces), applied to a model;
* :mod:`~xfemcontact.history.stepping`: the load steps from one instant of
  ``[instants]`` to the next, with automatic cutting of a step that does not
  converge (``[instants.echec]``), tests at their instants, one progress line per
  step;
* :mod:`~xfemcontact.history.checkpoint`: completed steps on disk, beside the
  output folder, and the restart from them.
"""
