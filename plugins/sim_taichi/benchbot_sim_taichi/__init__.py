"""BenchBot plugin package."""
