"""One module per ``mpmpp`` subcommand: ``add_arguments(parser)`` and ``run(args)``."""
