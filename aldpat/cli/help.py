"""``--help`` that guides: examples first, then the options grouped by how often they are needed.

Every option carries the level its parameter declares (:data:`aldpat.params.LEVELS`): the
common options are listed first, then the advanced ones, then the published method's internals.
The examples are the task's own (:attr:`aldpat.jobs.task.Task.examples`).
"""

from __future__ import annotations

from typing import Any

import click

from aldpat.params import LEVELS

#: Options of every command that are not parameters (``--params``, ``--dry-run``, ``-v``, ``-q``, ``--help``):
#: listed with the common ones.
DEFAULT_LEVEL = "common"


def with_level(param: click.Parameter, level: str) -> click.Parameter:
    """``param``, listed under ``level``'s heading in ``--help``."""
    param.aldpat_level = level  # type: ignore[attr-defined]
    return param


def write_examples(formatter: click.HelpFormatter, examples: tuple[tuple[str, str], ...]) -> None:
    """Each example's command line, and under it what it does."""
    if not examples:
        return
    with formatter.section("Examples"):
        for i, (command, what) in enumerate(examples):
            if i:
                formatter.write("\n")
            formatter.write(f"{'':>{formatter.current_indent}}{command}\n")
            with formatter.indentation(), formatter.indentation():
                formatter.write_text(what)


class Guided(click.Command):
    """Help that opens on the command's text, a paragraph of guidance (:meth:`guide`) and the
    examples, then lists the options by level."""

    examples: tuple[tuple[str, str], ...] = ()

    def guide(self, ctx: click.Context) -> str:
        """Advice printed after the help text (none by default)."""
        return ""

    def format_help_text(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        super().format_help_text(ctx, formatter)
        advice = self.guide(ctx)
        if advice:
            formatter.write_paragraph()
            with formatter.indentation():
                formatter.write_text(advice)
        write_examples(formatter, self.examples)

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        groups: dict[str, list[tuple[str, str]]] = {level: [] for level in LEVELS}
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is not None and not isinstance(param, click.Argument):
                groups[getattr(param, "aldpat_level", DEFAULT_LEVEL)].append(record)
        for level, records in groups.items():
            if records:
                with formatter.section(LEVELS[level]):
                    formatter.write_dl(records)


class GuidedCommand(Guided):
    """A command with its examples (:attr:`aldpat.jobs.task.Task.examples`)."""

    def __init__(self, *args: Any, examples: tuple[tuple[str, str], ...] = (), **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.examples = examples


class GuidedGroup(Guided, click.Group):
    """A group of commands with examples; an unknown command is reported with a suggestion."""

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        super().format_options(ctx, formatter)  # the options by level (Guided's), then the commands
        self.format_commands(ctx, formatter)

    def resolve_command(self, ctx: click.Context, args: list[str]
                        ) -> tuple[str | None, click.Command | None, list[str]]:
        try:
            return super().resolve_command(ctx, args)
        except click.UsageError:
            import difflib

            hint = difflib.get_close_matches(args[0], list(self.commands), n=1) if args else []
            raise click.UsageError(f"no command {args[0]!r}" + (f"; did you mean {hint[0]!r}?" if hint else "")) from None
