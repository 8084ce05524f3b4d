"""BenchBot plugin: the Object Map Quality (OMQ) evaluation method (see :mod:`benchbot_eval_omq.omq`)."""
