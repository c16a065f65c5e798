"""Click options derived from parameter specs (the one declaration in aldpat.params).

Every value reaches the library as the user typed it and is validated by
:func:`aldpat.params.coerce`, so the command line, worksheets and ``--params`` files give the
same messages for the same mistakes.
"""

from __future__ import annotations

import dataclasses

import click

from aldpat.cli.help import with_level
from aldpat.params import Spec

#: short spellings of a few common options
SHORT = {"jobs": "-j", "output": "-o"}


def option_for(spec: Spec) -> click.Option:
    """The option of ``spec``, listed in ``--help`` under the heading of its level."""
    option = _option(spec)
    with_level(option, spec.level)
    return option


def _option(spec: Spec) -> click.Option:
    names = [spec.option]
    if spec.name in SHORT:
        names.insert(0, SHORT[spec.name])
    help_text = spec.describe()
    if spec.kind == "bool":
        return click.Option([f"{spec.option}/--no-{spec.option[2:]}"] if spec.default else names,
                            is_flag=True, default=None, help=help_text)
    if spec.is_sequence and spec.length:
        return click.Option(names, nargs=spec.length, type=str, default=None, help=help_text,
                            metavar=spec.metavar or " ".join(["V"] * spec.length))
    metavar = spec.metavar
    if metavar is None:
        if spec.choices:
            metavar = "[" + "|".join(map(str, spec.choices)) + "]"
        elif spec.is_sequence:
            metavar = "A,B,..."
        else:
            metavar = {"int": "INT", "float": "FLOAT", "str": "TEXT"}.get(spec.kind, "VALUE")
            if spec.path:
                metavar = "FILE"
    return click.Option(names, type=str, default=None, help=help_text, metavar=metavar)


def renamed_option(spec: Spec, old: str) -> click.Option:
    """A hidden option under an earlier name of ``spec``; the value reaches
    :func:`aldpat.params.with_current_names`, which says it was renamed."""
    option = option_for(dataclasses.replace(spec, name=old, renamed_from=()))
    option.hidden = True
    return option


params_file_opt = click.Option(["--params", "params_file"], type=str, default=None, metavar="FILE.toml",
                               help="TOML file supplying any parameter; options given here win over it")
