"""``itensor paper``: the paper's experiments, reproduced.

``evaluate`` runs Table 1's protocol on scenes, ``merge`` joins runs made on disjoint scene
subsets, ``rejudge`` judges a finished run again with the current judge, ``tune`` chooses each
affordance's acceptance on the procedural validation rooms. Registered as an ``itensor``
command group through the ``interaction_tensor.commands`` entry point: the library finds it
when this package is installed and never imports it otherwise.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from interaction_tensor.cli.common import (
    _fraction,
    _spacing,
    examples_option,
    number,
    objects_dir,
    quiet_option,
    seed_option,
)
from interaction_tensor.errors import InputError
from itensor_paper.merge import merge, rejudge
from itensor_paper.report import judge_markdown, table_markdown
from itensor_paper.runner import METHODS, EvalSettings, evaluate
from itensor_paper import panel
from itensor_paper.common import write_csv
from itensor_paper.summary import write_summary
from itensor_paper.tuning import TuneSettings, tune, write

_positive_int = number(int, low=1, what="a positive integer")


def _id_letter(text: str) -> str:
    """A new panel round's id letter: one capital letter."""
    if len(text) == 1 and "A" <= text <= "Z":
        return text
    raise argparse.ArgumentTypeError(f"{text!r} is not one capital letter")
_examples = examples_option
_objects_dir = objects_dir


def cmd_evaluate(args) -> int:

    methods = tuple(args.methods.split(",")) if args.methods else METHODS
    st = EvalSettings(examples=_examples(args.examples), objects_dir=_objects_dir(args.objects),
                      test_points=args.test_points, sample_fraction=args.sample_fraction,
                      max_candidates=args.max_candidates,
                      max_bs_candidates=args.max_bs_candidates, methods=methods,
                      pictures=not args.no_pictures, seed=args.seed, spacing=args.spacing,
                      judge_check=not args.no_judge_check)
    log = (lambda _s: None) if args.quiet else (lambda s: print(s, flush=True))
    res = evaluate(list(args.scenes), args.output, st, log)
    if not args.quiet:

        print(table_markdown(res.table, methods))
        if res.judge_accuracy:
            print("\nThe judge on its labelled poses:\n" + judge_markdown(res.judge_accuracy))
        print(f"wrote {args.output}/table1.md, table1.csv, sampling.md/.csv/.png, timings.md, "
              f"judgements.csv, pictures/ in {res.settings['total_seconds']} s")
    return 0


def cmd_tune(args) -> int:

    if args.top_candidates < 1:
        raise InputError("--top-candidates", "must be at least 1")
    st = TuneSettings(examples=_examples(args.examples), objects_dir=_objects_dir(args.objects),
                      seed=args.seed, objective=args.objective,
                      top_candidates=args.top_candidates, criterion=args.criterion)
    log = (lambda _s: None) if args.quiet else (lambda s: print(s, flush=True))
    res = tune(st, log)
    write(res, args.output)
    if not args.quiet:
        for aff, ch in res.chosen.items():
            mode, dist, frac, angle = ch["contact"]
            print(f"{aff:<8} S_aff {ch['threshold']:.3f}  clearance limit "
                  f"{ch['clearance_limit']:.2f}  interior limit {ch['interior_limit']:.2f}  "
                  f"contact {mode} {dist:g} m {frac:g} {angle:g} deg")
        print(f"wrote {args.output}/tuning.md, tuning.json, tuning_pairs.csv in "
              f"{res.settings['total_seconds']} s")
    return 0


def cmd_evaluate_merge(args) -> int:

    log = (lambda _s: None) if args.quiet else (lambda s: print(s, flush=True))
    res = merge(args.runs, args.output, log, allow=args.allow_differing, replace=args.replace)
    if not args.quiet:
        print(table_markdown(res.table, tuple(res.settings.get("methods") or ())))
        if res.judge_accuracy:
            print("\nThe judge on its labelled poses:\n" + judge_markdown(res.judge_accuracy))
    return 0


def cmd_evaluate_rejudge(args) -> int:

    log = (lambda _s: None) if args.quiet else (lambda s: print(s, flush=True))
    res = rejudge(args.run, args.output, args.scenes, args.objects,
                  tuple(args.affordances) if args.affordances else None,
                  judge_check=not args.no_judge_check, log=log)
    if not args.quiet:
        print(table_markdown(res.table, tuple(res.settings.get("methods") or ())))
        if res.judge_accuracy:
            print("\nThe judge on its labelled poses:\n" + judge_markdown(res.judge_accuracy))
    return 0


def cmd_panel_sheets(args) -> int:
    import csv

    source = Path(args.run)
    if source.suffix == ".csv":             # a panel's own poses (its key, or panel.csv),
        poses = panel.load(source)          # for a new round of raters
        if args.affordance:
            poses = [p for p in poses if p.affordance in args.affordance]
        for p in poses:
            p.answers = []
    else:
        path = source / "judgements.csv"
        if not path.is_file():
            raise InputError(source, "not an evaluation output (no judgements.csv) nor a "
                                     "panel's CSV")
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
        if args.unseen:                     # a new round, held out whole
            poses = panel.new_round(rows, panel.load(args.unseen), args.per_affordance,
                                    args.seed, args.affordance, args.prefix)
        else:
            held = sorted({r["scene"] for r in rows} - set(panel.DEVELOPMENT_SCENES))
            dev = panel.select(rows, args.development, args.seed,
                               scenes=panel.DEVELOPMENT_SCENES)
            hold = panel.select(rows, args.per_affordance, args.seed + 1, scenes=held,
                                first_id=len(dev) + 1)
            poses = panel.shuffled_ids(dev + hold, args.seed + 2)
    panel.draw(poses, args.scenes, objects_dir(args.objects), args.output)
    if not args.quiet:
        print(f"wrote {len(poses)} poses' rating sheets and key.csv into {args.output}")
    return 0


def cmd_panel_verdicts(args) -> int:
    poses = panel.merge_answers(panel.load(args.key), *args.answers)
    out = Path(args.output)
    if out.exists() and out.resolve() != Path(args.key).resolve():
        poses = panel.add_round(panel.load(out), poses)      # a new round beside the rest
    panel.save(poses, out)
    if not args.quiet:
        decided = sum(p.majority is not None for p in poses)
        print(f"wrote {args.output}: {len(poses)} poses, {decided} with a majority")
    return 0


def cmd_panel_agreement(args) -> int:
    poses = panel.load(args.panel)
    judged = panel.judge_poses(poses, args.scenes, objects_dir(args.objects),
                               None if args.quiet else print)
    rows = panel.agreement_rows(poses, judged)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "panel_agreement.csv", rows, panel.AGREEMENT_COLUMNS)
    if not args.quiet:
        print(panel.agreement_markdown(rows))
    return 0


def cmd_own(args) -> int:
    from itensor_paper import own
    from interaction_tensor.geometry.files import atomic_dir

    st = own.OwnSettings(examples=tuple(args.examples or own.OwnSettings().examples),
                         top_k=args.top_k, sample_fraction=args.sample_fraction,
                         seed=args.seed)
    log = (lambda _s: None) if args.quiet else (lambda s: print(s, flush=True))
    with atomic_dir(args.output, "own.md", ("own.md", "own.csv", "results")) as tmp:
        rows = own.evaluate(st, tmp / "results", log)
        own.write(rows, tmp)
    if args.summary:
        own.write(rows, args.summary)
    if not args.quiet:
        print(own.summary_markdown(rows))
    return 0


def cmd_summary(args) -> int:
    out = write_summary(args.run, args.output)
    if not args.quiet:
        print(f"wrote {out}/table1.md, table1.csv, judge_accuracy.csv, pictures/")
    return 0


def register(sub) -> None:
    """Add the ``paper`` command group to the ``itensor`` subparsers."""
    group = sub.add_parser("paper", help="reproduce the paper's experiments (Table 1, the judge, "
                                         "tuning on validation rooms)")
    sub = group.add_subparsers(dest="paper_command", metavar="ACTION", required=True)
    p = sub.add_parser("tune", help="tune the acceptance (S_aff and the placement tests) of each "
                                    "affordance on the procedural validation scenes")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--objects", default=None, help="directory of real query objects")
    p.add_argument("--examples", nargs="*", help="only these examples (default: all 8)")
    p.add_argument("--objective", choices=("top", "f1"), default="top",
                   help="choose the placement tests by their validation top 5 judged valid "
                        "(top, Table 1's measure, default) or by the F1 of the pair "
                        "decisions (f1)")
    p.add_argument("--top-candidates", type=int, default=30,
                   help="placement tests of largest F1 tried by the top objective (30)")
    p.add_argument("--criterion", choices=("paper", "gaussian"), default="paper",
                   help="score criterion of the pairs: paper (mesh scenes) or gaussian (the "
                        "default of captured scenes; tuning.md then gives its S_aff for the "
                        "shipped placement tests)")
    seed_option(p)
    quiet_option(p)
    p.set_defaults(func=cmd_tune)

    p = sub.add_parser("evaluate", help="reproduce the paper's experiments on scenes")
    p.add_argument("--scenes", nargs="+", required=True,
                   help="scene files or directories (metres, +Z up)")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--examples", nargs="*", help="only these examples (default: all 8)")
    p.add_argument("--objects", default=None, help="directory of real query objects")
    p.add_argument("--methods", default=None,
                   help="comma-separated subset of iT-weighted,iT-uniform,Naive,BS")
    p.add_argument("--sample-fraction", type=_fraction, default=0.30,
                   help="fraction of scene points drawn as test points (default: the paper's "
                        "0.30)")
    p.add_argument("--test-points", type=_positive_int, default=None,
                   help="a fixed number of test points per scene instead of the fraction")
    p.add_argument("--max-candidates", type=_positive_int, default=64,
                   help="candidates scored by the Naive baseline per (example, scene) "
                        "(default 64)")
    p.add_argument("--max-bs-candidates", type=_positive_int, default=12,
                   help="candidates scored by the BS baseline per (example, scene) (default 12)")
    p.add_argument("--spacing", type=_spacing, default=0.01, help="sampling spacing (m)")
    p.add_argument("--no-pictures", action="store_true",
                   help="skip the close-up pictures of the judged poses (faster)")
    p.add_argument("--no-judge-check", action="store_true",
                   help="skip judging the labelled poses (e.g. in all but one of the runs "
                        "that `itensor evaluate-merge` will combine)")
    seed_option(p)
    quiet_option(p)
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("rejudge",
                       help="judge a finished `itensor evaluate` run again with the current "
                            "judge (no detection): new verdicts, tables and pictures")
    p.add_argument("run", help="output directory of the run")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--scenes", required=True, help="directory of the run's scene files")
    p.add_argument("--objects", default=None,
                   help="directory of the real query objects (default: the run's own)")
    p.add_argument("--affordances", nargs="+", default=None,
                   choices=("placing", "sitting", "filling", "riding", "hanging"),
                   help="judge only these affordances' poses again (default: all)")
    p.add_argument("--no-judge-check", action="store_true",
                   help="keep the run's labelled-set accuracy instead of measuring it again")
    quiet_option(p)
    p.set_defaults(func=cmd_evaluate_rejudge)

    p = sub.add_parser("merge",
                       help="merge `itensor evaluate` runs made on disjoint scene subsets "
                            "(or, with --replace, a method run again)")
    p.add_argument("runs", nargs="+", help="output directories of the runs (same settings)")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--allow-differing", default=(), metavar="KEY[,KEY...]",
                   type=lambda t: tuple(k.strip() for k in t.split(",") if k.strip()),
                   help="settings of run.json the runs may hold differently (e.g. icp_backend); "
                        "the merged run.json lists each run's value under per_part "
                        "(default: none, all settings must agree)")
    p.add_argument("--replace", action="store_true",
                   help="the runs may share scenes: a later run's results for a (scene, "
                        "example, method) it ran replace the earlier runs' (a method or some "
                        "examples evaluated again, e.g. after new tuning; their methods and "
                        "examples are listed under per_part)")
    quiet_option(p)
    p.set_defaults(func=cmd_evaluate_merge)

    p = sub.add_parser("summary", help="copy the current figures of an evaluation (Table 1, the "
                                       "judge's accuracy, one picture per affordance) into the "
                                       "tracked summary the README quotes")
    p.add_argument("run", help="output directory of an evaluation (evaluate, merge, rejudge)")
    p.add_argument("-o", "--output", default="paper/results",
                   help="the summary folder (replaced whole)")
    quiet_option(p)
    p.set_defaults(func=cmd_summary)

    from itensor_paper.own import EXAMPLES as OWN

    p = sub.add_parser("own", help="train six interactions of a user's own without a preset "
                                   "and judge what detection accepts in rooms that hold a "
                                   "place for them and rooms that hold none")
    p.add_argument("-o", "--output", required=True,
                   help="output directory (own.md, own.csv, each result in results/)")
    p.add_argument("--examples", nargs="*", choices=[e.name for e in OWN], metavar="EXAMPLE",
                   help="only these (default: all six: "
                        + ", ".join(e.name for e in OWN) + ")")
    p.add_argument("--top-k", type=_positive_int, default=10,
                   help="predictions judged per room")
    p.add_argument("--sample-fraction", type=_fraction, default=None,
                   help="test-point fraction (default: detect's)")
    p.add_argument("--summary", default=None,
                   help="also write own.md and own.csv here (paper/results: the tracked copy)")
    seed_option(p)
    quiet_option(p)
    p.set_defaults(func=cmd_own)

    p = sub.add_parser("panel-sheets",
                       help="draw rating sheets for a blind panel from an evaluation's judged "
                            "poses (three views and two cuts each, one colour, ids only) and "
                            "their key")
    p.add_argument("run", help="output directory of an evaluation (its judgements.csv), or a "
                               "panel's CSV (its key, or data/panel.csv) to draw its poses "
                               "again for new raters")
    p.add_argument("--affordance", action="append", default=None,
                   help="with a panel's CSV or --unseen: only this affordance's poses "
                        "(repeatable)")
    p.add_argument("--unseen", default=None, metavar="PANEL_CSV",
                   help="a new round: --per-affordance poses from every scene that this "
                        "panel has not shown, all held out")
    p.add_argument("--prefix", default="R", type=_id_letter,
                   help="with --unseen: the letter of the new round's ids (default R)")
    p.add_argument("-o", "--output", required=True, help="folder of the sheets and the key")
    p.add_argument("--scenes", required=True, help="directory of the run's scene files")
    p.add_argument("--objects", default=None, help="directory of real query objects")
    p.add_argument("--per-affordance", type=_positive_int, default=64,
                   help="held-out poses per affordance (from the scenes the judge is not "
                        "fixed on)")
    p.add_argument("--development", type=_positive_int, default=40,
                   help="poses per affordance from the development scenes")
    seed_option(p)
    quiet_option(p)
    p.set_defaults(func=cmd_panel_sheets)

    p = sub.add_parser("panel-agreement",
                       help="judge the blind panel's poses and write how often the judge "
                            "agrees with the panel (panel_agreement.csv)")
    p.add_argument("--scenes", required=True, help="directory of the panel's scene files")
    p.add_argument("--objects", default=None, help="directory of real query objects")
    p.add_argument("--panel", default=str(panel.DATA_FILE),
                   help="the panel's poses and verdicts (default: the package's)")
    p.add_argument("-o", "--output", default="paper/results",
                   help="folder to write panel_agreement.csv into")
    quiet_option(p)
    p.set_defaults(func=cmd_panel_agreement)

    p = sub.add_parser("panel-verdicts",
                       help="add raters' answers (CSV files of id,yes|no) to a panel's key: "
                            "the labelled data the judge is checked against")
    p.add_argument("key", help="the panel's key.csv (or the labelled data to add answers to)")
    p.add_argument("answers", nargs="+", help="one CSV of id,answer per rater")
    p.add_argument("-o", "--output", default=str(panel.DATA_FILE),
                   help="the labelled data to write the poses and verdicts into (a new "
                        "round's poses are added to what it holds)")
    quiet_option(p)
    p.set_defaults(func=cmd_panel_verdicts)
