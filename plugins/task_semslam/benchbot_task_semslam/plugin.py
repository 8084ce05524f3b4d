"""Hook implementations (filled in by the plugin)."""
