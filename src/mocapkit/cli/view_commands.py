"""``mocapkit view`` (registered on import; see mocapkit.cli)."""
