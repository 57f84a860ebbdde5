"""Pipelines across stages: the demos (measure, identify, tune, test, compare) and the files they write."""
