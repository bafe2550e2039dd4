"""``mocapkit graph`` subcommands (registered on import; see mocapkit.cli)."""
