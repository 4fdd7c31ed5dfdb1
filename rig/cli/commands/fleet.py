"""``rig fleet RESULTS [--by lot|rig|model|month] [--threshold Z] [--json] [--against OLD_RESULTS]
[--plot FILE.png] [-o FLEET.html]``: statistics across re-solved units, their figure and their HTML page."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

from rig.analysis import plots
from rig.archive.fleet import GROUPS, changes, fleet
from rig.archive.resolve import RESULTS_FILE
from rig.cli import outputs
from rig.cli.common import EXIT_OK

#: the resolution of the --plot file (the page embeds the figure at the report's own)
PLOT_DPI = 110


def add_parser(sub) -> None:
    f = sub.add_parser("fleet", help="statistics across the units of a re-solved archive: spread, units that stand out")
    f.add_argument("results", help="a rig resolve results folder")
    f.add_argument("--by", choices=list(GROUPS), default=None, help="group by lot, rig file, sensor model or month")
    f.add_argument("--threshold", type=float, default=None,
                   help="robust z beyond which a unit stands out (default 5); with --against, the change in combined "
                        "sigmas beyond which a session is listed (default 3)")
    f.add_argument("--json", action="store_true")
    f.add_argument("--against", default=None, metavar="OLD_RESULTS",
                   help="the change of every parameter from these results (the same archive solved before)")
    f.add_argument("--plot", default=None, metavar="FILE.png",
                   help="per parameter each group's units, the robust band and the units beyond it (with --against: "
                        "each session's change in combined sigmas); a directory: fleet.png written inside it")
    f.add_argument("-o", "--output", default=None, metavar="FLEET.html",
                   help="one self-contained HTML page: the summary, the units that stand out, the figure and the "
                        "results' provenance (a directory: fleet.html written inside it)")
    f.add_argument("--follow", action="store_true", help=outputs.FOLLOW_HELP)


def run(args) -> int:
    plot, page = _targets(args)
    if args.against is not None:
        return _changes(args, plot, page)
    threshold = 5.0 if args.threshold is None else args.threshold
    groups = fleet(args.results, by=args.by, threshold=threshold)
    if args.json:
        print(json.dumps({"format": "rig-fleet/1", "by": args.by, "threshold": threshold,
                          "groups": [dataclasses.asdict(g) for g in groups]}, indent=2))
    else:
        _print_groups(groups, args.by, threshold)
    if plot is not None or page is not None:
        from rig.archive import fleet_page  # deferred: matplotlib and the report's renderer, only when asked for
        _written(args, plot, page, *fleet_page.fleet_outputs(args.results, groups, args.by, threshold, page is not None))
    return EXIT_OK


def _print_groups(groups, by, threshold: float) -> None:
    for g in groups:
        print(f"{by or 'fleet'} {g.group}: {g.n} units solved" + (f", {g.failed} failed" if g.failed else ""))
        for name, p in g.parameters.items():
            print(f"  {name:<8} median {p['median']:+10.2f}  spread {p['spread']:8.2f} {p['unit']} (1.4826 MAD)")
        if g.outliers:
            print(f"  standing out (|robust z| > {threshold:g}):")
            for o in g.outliers:
                print(f"    {o['session_id']}: {o['parameter']} {o['value']:+.2f} (z {o['z']:+.1f})")
        else:
            print(f"  no unit beyond {threshold:g} robust sigmas")


def _changes(args, plot, page) -> int:
    """``--against OLD``: each parameter's change from the old results, in its unit and combined sigmas."""
    threshold = 3.0 if args.threshold is None else args.threshold
    found = changes(args.results, args.against, threshold)
    if args.json:
        print(json.dumps({"format": "rig-fleet-change/1", "new": args.results, "old": args.against,
                          "threshold": threshold, "changes": [dataclasses.asdict(c) for c in found]}, indent=2))
    else:
        print(f"change from {args.against} to {args.results} over {found[0].n} sessions solved in both "
              f"(z: the change over the two solves' combined sigma):")
        for c in found:
            print(f"  {c.parameter:<8} mean {c.mean:+10.3f} {c.unit:<8} mean z {c.mean_z:+6.2f}  largest z "
                  f"{c.largest_z:+6.2f}" + (f"  {len(c.beyond)} beyond {threshold:g}" if c.beyond else ""))
    if plot is not None or page is not None:
        from rig.archive import fleet_page  # deferred: matplotlib and the report's renderer, only when asked for
        _written(args, plot, page, *fleet_page.change_outputs(args.results, args.against, found, threshold,
                                                              page is not None))
    return EXIT_OK


def _written(args, plot, page, fig, text: str | None) -> None:
    """Write the figure to ``plot`` and the page to ``page`` (those given); say where (on stderr under --json:
    stdout is the document)."""
    where = sys.stderr if args.json else sys.stdout
    if plot is not None:
        print(f"plot: {outputs.write_figure(plot, fig, PLOT_DPI)}", file=where)
    if page is not None:
        print(f"page: {outputs.write(page, text)}", file=where)


def _targets(args) -> tuple[outputs.Output | None, outputs.Output | None]:
    """``--plot`` and ``-o``, checked before anything is read: the output policy's rules (docs/cli.md, "Output
    paths"), a plot's suffix, and never inside a results folder or the archive they were solved from."""
    inputs = [args.results] + ([args.against] if args.against else [])
    policy = outputs.OutputPolicy(inputs=inputs, follow=args.follow)
    plot = page = None
    name = "fleet-change" if args.against else "fleet"
    if args.plot is not None:
        plot = _not_in_results(policy.file(args.plot, option="--plot", what="the plot", directory=True), inputs)
        plots.resolve_plot_path(args.plot, f"{name}.png")  # the suffix and the folder (one given with / is made)
        plot = plot.inside(f"{name}.png") if plot.directory else plot
    if args.output is not None:
        page = _not_in_results(policy.file(args.output, what="the page", directory=True), inputs)
        if page.directory:
            Path(page.path).mkdir(parents=True, exist_ok=True)
            page = page.inside(f"{name}.html")
    return plot, page


def _not_in_results(out: outputs.Output, inputs: list[str]) -> outputs.Output:
    """``out``, unless it is or is inside a results folder (those given, or any holding ``resolve.json``) or the
    archive they were solved from: then one line, exit 2."""
    real = Path(out.path).expanduser().resolve()
    protected = []
    for item in inputs:
        folder = Path(item).expanduser().resolve()
        protected.append((folder, "the results folder"))
        try:
            archive = json.loads((folder / RESULTS_FILE).read_text()).get("archive")
        except (OSError, ValueError, AttributeError):
            archive = None
        if archive:
            protected.append((Path(archive).resolve(), "the archive"))
    protected += [(d, "a results folder") for d in [real, *real.parents] if (d / RESULTS_FILE).is_file()]
    for folder, what in protected:
        if folder == real or folder in real.parents:
            raise out.refuse(f"is inside {what} {folder}: results and archives are never written into; write "
                             "elsewhere")
    return out
