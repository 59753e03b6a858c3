"""The plug-in's worlds (``*.toml`` here; ``slam worlds`` lists them)."""
