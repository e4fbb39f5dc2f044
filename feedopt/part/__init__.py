"""The predicted part (issue 33): the walls and floor the deflected tool leaves, measured per
segment like the thesis's CMM did (:mod:`feedopt.part.envelope`, :mod:`feedopt.part.measure`,
:mod:`feedopt.part.output`)."""
