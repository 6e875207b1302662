"""Features users run beside the chart: the path-traced reference, comparisons, animations
and docs builds (the gallery and the Sphinx directive's renders)."""
