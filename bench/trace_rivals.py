"""``bench/trace_replays.py`` with every simulated rival's judgement printed: why a rival replayed over the whole log
is listed or not (its size from the fitting part, then the held-out check and delta BIC of
:func:`ur5fault.discrepancy.rivals.judge_rival`, which decide on the held-out samples).

    python bench/trace_rivals.py discrepancy data/nist-ur5/ur5testresult_halfspeed_payload1.6lb_1.csv.gz \\
        --format nist --out /tmp/d --jobs 2 --quiet
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv: list[str]) -> int:
    import trace_replays

    import ur5fault.discrepancy.rivals as rv
    from ur5fault.discrepancy.statistics import BlockGram, generalisation, rss_of

    judge_rival, in_place = rv.judge_rival, rv.in_place

    def traced_judge(e_place, col, e_named, n_fit, ch, drift=None, others=None):
        got = judge_rival(e_place, col, e_named, n_fit, ch, drift, others)
        if others is None or not len(others):  # list_rivals' rivals: the rival alone in the finding's place
            X_fit, e_fit = col[None, :n_fit], e_place[:n_fit]
            if drift is not None:
                X_fit, e_fit = drift.remove(X_fit), drift.remove(e_fit)
            G, g, ee = BlockGram.build(X_fit, e_fit).total()
            b = float(rss_of(G, g, ee, [0])[1][0])
            held = e_place[n_fit:] - b * col[n_fit:]
            gen = generalisation(held[:, ch], (held + b * col[n_fit:])[:, ch])
            dbic = rv.held_out_delta_bic(e_named[n_fit:][:, ch], held[:, ch])
            print(f"rival: size x{b:.3f} of its linearised one (fitting part); held-out check "
                  f"{('passes' if gen.passes else 'fails') if gen.testable else 'not testable (too small a change)'} "
                  f"(ratio {gen.ratio:.3f}), delta BIC {dbic:.1f} "
                  f"(listed below {rv.MIN_DELTA_BIC:g}) -> {'listed' if got else 'not listed'}",
                  file=sys.stderr, flush=True)
        return got

    def traced_in_place(X, e_place, e_named, candidates, cols, taken, joint, *args, **kwargs):
        out = in_place(X, e_place, e_named, candidates, cols, taken, joint, *args, **kwargs)
        print(f"rivals planned for joint {joint}: {[candidates[k].label for k, _ in out]}", file=sys.stderr, flush=True)
        return out

    rv.judge_rival, rv.in_place = traced_judge, traced_in_place
    return trace_replays.main(argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
