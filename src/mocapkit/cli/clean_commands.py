"""``mocapkit clean`` subcommands (registered on import; see mocapkit.cli)."""
