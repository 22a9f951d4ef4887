"""One module per ``handeye`` command; each has ``add_parser(subparsers)`` and ``run(args)``."""
