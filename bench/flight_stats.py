"""Frame statistics of a flight that `tellus render --path ... --repeat 2 --stats FILE` flew twice
in one renderer: pass 1 as streamed, pass 2 the same views with everything resident (each view's
own cost). Used by bench/render.sh and bench/pacing.sh."""
import json


def nearest_rank(values, percent):
    ordered = sorted(values)
    return ordered[max(1, -(-percent * len(ordered) // 100)) - 1]


def flight(stats_path):
    s = json.load(open(stats_path))
    t = s["frame_times_ms"]
    n = len(t) // 2
    streamed, settled = t[:n], t[n:]
    ratio = [x / y for x, y in zip(streamed, settled)]  # a frame against the same view settled
    return {
        "seconds": s["seconds"],
        "median": nearest_rank(streamed, 50),
        "p95": nearest_rank(streamed, 95),
        "longest": max(streamed),
        "settled_median": nearest_rank(settled, 50),
        "settled_longest": max(settled),
        "ratio_median": nearest_rank(ratio, 50),
        "ratio_p95": nearest_rank(ratio, 95),
        "ratio_max": max(ratio),
    }
