"""One module per ``handeye`` command; each has ``add_parser(subparsers)`` and ``run(args)``."""

#: The page that defines the figures the commands print (1-sigma, residual, axis diversity, matched, ...).
GLOSSARY = "docs/concepts/glossary.md"
