"""``mocapkit stitch`` subcommands (registered on import; see mocapkit.cli)."""
