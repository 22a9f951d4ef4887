"""One module per ``handeye`` command; each has ``add_parser(subparsers)`` and ``run(args)``."""

import argparse

#: The page that defines the figures the commands print (1-sigma, residual, axis diversity, matched, ...).
GLOSSARY = "docs/concepts/glossary.md"
#: How the commands print where it is: a path in the repository (the project names no documentation site URL:
#: mkdocs.yml has no ``site_url``), so a reader outside the repository knows where to look.
GLOSSARY_WHERE = f"{GLOSSARY} (in the repository)"


def command_parser(sub, name: str, help: str, doc: str | None) -> argparse.ArgumentParser:
    """A command's (or subcommand's) parser: ``help`` its line in the list of commands, ``doc`` (its module's
    docstring) its description, printed as written."""
    return sub.add_parser(name, help=help, description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
