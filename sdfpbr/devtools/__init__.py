"""Tools for the project's developers: the benchmark, the stress sweep, the seed-shader
baseline and the white-furnace energy report. Users' features live in sdfpbr.features."""
