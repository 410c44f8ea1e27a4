"""``siftom bench reproduce`` and ``siftom bench pages``: every number the docs quote, from data."""

from __future__ import annotations

import click

from siftom.cli.bench import _backend, _backend_options, _csv, bench_group


@click.command("reproduce")
@click.option("--plan", "plan_path", type=click.Path(dir_okay=False), default="results/plan.toml", show_default=True,
              help="TOML plan: the evaluation sets (domain, seed, voices, noises, phrasings, models)")
@click.option("--out", "out", type=click.Path(file_okay=False), default="results", show_default=True,
              help="results folder: NAME.json per set (datasets and raw results go to OUT/runs/)")
@click.option("--only", default=None, help="comma-separated set names (default: every set)")
@click.option("--workers", type=int, default=None, help="processes or Ray CPUs (default: number of CPUs, at most 4)")
@_backend_options
@click.option("--docs", "docs_dir", type=click.Path(file_okay=False), default="docs/results", show_default=True,
              help="where the results pages go; '' to skip them")
@click.option("--readme", type=click.Path(dir_okay=False), default="README.md", show_default=True,
              help="README whose results block is refreshed; '' to skip it")
def reproduce_cmd(plan_path: str, out: str, only: str | None, workers: int | None, backend: str,
                  ray_address: str | None, docs_dir: str, readme: str) -> None:
    """Build and evaluate every set of a plan, write stamped summaries, then the results pages."""
    from siftom.bench.pages import write_pages
    from siftom.bench.reproduce import load_plan, reproduce

    plan = load_plan(plan_path)
    with _backend(backend, workers, ray_address) as be:
        results = reproduce(plan, out, be, only=tuple(_csv(only)), progress=click.echo)
    for r in results:
        click.echo(f"wrote {out}/{r.set}.json ({r.dataset.stimuli} stimuli, {r.seconds[1]:.0f} s)")
    if docs_dir:
        for p in write_pages(out, docs_dir, readme or None):
            click.echo(f"wrote {p}")


@click.command("pages")
@click.option("--results", "results_dir", type=click.Path(file_okay=False), default="results", show_default=True,
              help="folder of NAME.json files written by 'siftom bench reproduce'")
@click.option("--docs", "docs_dir", type=click.Path(file_okay=False), default="docs/results", show_default=True,
              help="where the results pages go")
@click.option("--readme", type=click.Path(dir_okay=False), default="README.md", show_default=True,
              help="README whose results block is refreshed; '' to skip it")
@click.option("--fill", "fill", type=click.Path(dir_okay=False), multiple=True,
              help="a docs page whose <!-- gen:... --> blocks are rewritten (results numbers, the constants "
                   "table); repeatable, e.g. --fill docs/benchmark.md --fill docs/explanation/constants.md")
def pages_cmd(results_dir: str, docs_dir: str, readme: str, fill: tuple[str, ...]) -> None:
    """Regenerate the results pages and the README's table from results files (no re-run)."""
    from siftom.bench.blocks import fill_pages
    from siftom.bench.pages import write_pages

    for p in write_pages(results_dir, docs_dir, readme or None):
        click.echo(f"wrote {p}")
    for p in fill_pages(results_dir, fill):
        click.echo(f"filled {p}")


def register(root: click.Group) -> None:
    """Add the results commands to the ``bench`` group."""
    bench = bench_group
    bench.add_command(reproduce_cmd)
    bench.add_command(pages_cmd)
