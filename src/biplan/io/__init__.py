"""Input/output: TOML configs, result files."""
