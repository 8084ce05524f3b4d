"""BenchBot plugin: the semantic SLAM / scene change detection tasks and the object-map results formats."""
