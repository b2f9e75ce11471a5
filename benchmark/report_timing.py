"""The report's timing section: single-episode latency beside the paper's Table I times,
then batched throughput. It sits between the ``<!-- timing -->`` and ``<!-- /timing -->``
markers, the only part of the report allowed to differ between two runs with the same
seed (:func:`strip_timing` removes it)."""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from . import paper_reference as paper
from .report_accuracy import GENERALISATION, accuracy_records, protocol_methods
from .tables import markdown_table, ms

TIMING_START = "<!-- timing -->"
TIMING_END = "<!-- /timing -->"
_TIMING_RE = re.compile(re.escape(TIMING_START) + r".*?" + re.escape(TIMING_END), re.S)


def strip_timing(text: str) -> str:
    """The report without its timing section (the part that is not reproducible)."""
    return _TIMING_RE.sub(TIMING_START + TIMING_END, text)


def timing_section(records: Sequence[dict]) -> list[str]:
    """Single-episode latency next to the paper's Table I times, then batched throughput
    in a separate table (the two are different measures)."""
    lines = [
        TIMING_START,
        "## Timing (wall clock; machine- and load-dependent, not part of the reproducible numbers)",
        "",
        "### Single-episode latency, closed-set 5-way-5-shot (the paper's Table I measure)",
        "",
        "Latency = mean wall time of adapting ONE episode at a time (support and queries "
        "of that episode only) and labelling its queries, in ms, without / with extracting "
        "the 386-feature pool of the episode's trials from raw signals (methods that read "
        "raw signals preprocess inside both). Pretrain = one fit on the training half (s). "
        "Paper: i9-12900HX + RTX 3080 Ti.",
        "",
    ]
    rows = []
    for m in protocol_methods(records, "closed-set"):
        rs = [
            r
            for r in accuracy_records(records, protocol="closed-set", method=m)
            if r["condition"] is None
        ]
        if not rs:
            continue
        five = next((r for r in rs if r["way"] == 5 and r["shot"] == 5), None)
        paper_time = paper.TABLE_ONE_TIME.get(m)
        rows.append(
            [
                m,
                f"{rs[0]['pretrain_s']:.2f}",
                ms(None if five is None else five.get("latency_ms_per_episode")),
                ms(None if five is None else five.get("latency_with_features_ms_per_episode")),
                "-" if five is None else str(five.get("latency_episodes") or "-"),
                "-" if paper_time is None else paper_time[0],
                "-" if paper_time is None else f"{paper_time[1]:g}",
            ]
        )
    if rows:
        lines += markdown_table(
            [
                "method",
                "pretrain (s)",
                "latency (ms), features precomputed",
                "latency (ms), incl. feature extraction",
                "episodes timed",
                "paper pretrain",
                "paper Adapt/episode (ms)",
            ],
            rows,
        )
    else:
        lines.append("Closed-set not run.")
    lines += [
        "",
        "### Batched throughput (not comparable with the paper's per-episode time)",
        "",
        "All of a record's episodes adapted in ONE call as stacked tensor problems, "
        "features precomputed; the call's wall time divided by the number of episodes "
        "(ms). Pretrain in s, mean over folds.",
        "",
    ]
    rows = []
    for protocol in ("closed-set", *GENERALISATION):
        for m in protocol_methods(records, protocol):
            rs = [
                r
                for r in accuracy_records(records, protocol=protocol, method=m)
                if r["fold"] is None
            ]
            rs = rs or accuracy_records(records, protocol=protocol, method=m)
            if protocol == "closed-set":
                rs = [r for r in rs if r["condition"] is None] or rs
            pick = next((r for r in rs if r["way"] == 5 and r["shot"] == 5), None)
            pick = pick or next((r for r in rs if r["way"] == 5), rs[0])
            rows.append(
                [
                    protocol,
                    m,
                    f"{np.mean([r['pretrain_s'] for r in rs]):.2f}",
                    f"{pick['adapt_ms_per_episode']:.2f}",
                    f"{pick['way']}-way-{pick['shot']}-shot, {pick['episodes']} episodes",
                ]
            )
    lines += markdown_table(
        ["protocol", "method", "pretrain (s)", "batched ms/episode", "task, batch size"], rows
    )
    lines += ["", TIMING_END, ""]
    return lines
