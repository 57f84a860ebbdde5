"""The drive cascade's law written once (:mod:`.law`), its per-sample runtime (:mod:`.runtime`), the twin of a
one-encoder axis it closes (:mod:`.twin`) and the analysis of its gains documents (:mod:`.gains_analysis`); the gains
format ``cascade`` names them (:mod:`feedtune.structures`)."""
