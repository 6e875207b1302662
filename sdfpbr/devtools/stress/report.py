"""What a sweep reports: a table per dimension and bucket, the worst of every metric, and each
failing configuration as a ready-to-run TOML spec."""
from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from ...files import atomic_file
from ...spec.fields import spec_to_toml
from .cases import TILED_TILE, Outcome
from .checks import FIREFLY_RATIO


@dataclass
class Report:
    outcomes: list
    notes: list
    seconds: float
    seed: int

    @property
    def failures(self) -> list:
        return [o for o in self.outcomes if o.failures]

    def worst(self, metric: str) -> float:
        return max((o.metrics.get(metric, 0.0) for o in self.outcomes), default=0.0)

    def table(self) -> list[dict]:
        """Per dimension and bucket: configurations, failures, worst display LSB, furnace error,
        firefly ratio, monotonic rise, mirror error."""
        rows = defaultdict(lambda: {"configs": 0, "failures": 0, "display_lsb": 0, "furnace_err": 0.0,
                                    "firefly_ratio": 0.0, "mirror_err": 0.0})
        for o in self.outcomes:
            labels = dict(o.case.labels)
            labels["silhouette min NdotV"] = ("<1e-3" if o.metrics.get("min_ndotv", 1) < 1e-3 else
                                              "<1e-2" if o.metrics.get("min_ndotv", 1) < 1e-2 else ">=1e-2")
            for dim, values in labels.items():
                for value in values if isinstance(values, list) else [values]:
                    r = rows[(dim, value)]
                    r["configs"] += 1
                    r["failures"] += bool(o.failures)
                    for m in ("display_lsb", "furnace_err", "firefly_ratio", "mirror_err"):
                        r[m] = max(r[m], o.metrics.get(m, 0))
        return [{"dimension": d, "value": v, **r} for (d, v), r in rows.items()]

    def to_json(self) -> dict:
        return {"seed": self.seed, "configs": len(self.outcomes), "failures": len(self.failures),
                "seconds": round(self.seconds, 1), "notes": self.notes,
                "worst": {m: self.worst(m) for m in ("display_lsb", "furnace_err", "firefly_ratio",
                                                      "monotonic_rise", "mirror_err")},
                "checked": {"firefly pixels": int(sum(o.metrics.get("firefly_tested", 0) for o in self.outcomes)),
                            "furnace pixels": int(sum(o.metrics.get("furnace_tested", 0) for o in self.outcomes))},
                "table": self.table(),
                "failing": [{"index": o.case.index, "kind": o.case.kind, "backend": o.case.backend,
                             "failures": o.failures} for o in self.failures]}

    def format(self) -> str:
        lines = [f"{'dimension':22s} {'value':16s} {'configs':>7s} {'fail':>5s} {'LSB':>4s} "
                 f"{'furnace':>8s} {'firefly':>8s} {'mirror':>8s}"]
        for r in sorted(self.table(), key=lambda r: (r["dimension"], str(r["value"]))):
            lines.append(f"{r['dimension'][:22]:22s} {str(r['value'])[:16]:16s} {r['configs']:7d} {r['failures']:5d} "
                         f"{r['display_lsb']:4d} {r['furnace_err']:8.2e} "
                         f"{r['firefly_ratio']:8.3g} {r['mirror_err']:8.2e}")
        j = self.to_json()
        w = j["worst"]
        lines.append("")
        lines.append(f"{j['configs']} configurations (seed {self.seed}), {j['failures']} failing, "
                     f"{self.seconds:.1f} s; "
                     f"worst: display {w['display_lsb']} LSB, furnace {w['furnace_err']:.2e}, "
                     f"firefly ratio {w['firefly_ratio']:.3g} (limit {FIREFLY_RATIO:g}), "
                     f"monotonic rise {w['monotonic_rise']:.2e}, BRDF mirror {w['mirror_err']:.2e}; "
                     f"{j['checked']['firefly pixels']} pixels firefly-tested, "
                     f"{j['checked']['furnace pixels']} furnace-tested")
        lines += self.notes
        for o in self.failures[:20]:
            lines.append(f"FAIL #{o.case.index} [{o.case.kind}, {o.case.backend}]: " + "; ".join(o.failures))
        if len(self.failures) > 20:
            lines.append(f"... and {len(self.failures) - 20} more")
        return "\n".join(lines)


def write_failure(directory: Path, outcome: Outcome) -> Path:
    case = outcome.case
    comments = [f"sdfpbr stress: configuration #{case.index} ({case.kind}, backend {case.backend}) failed:"]
    comments += [f"  {f}" for f in outcome.failures]
    if case.backend == "egl-tiled":
        comments.append(f"  (rendered with Session(..., tile={TILED_TILE}); sdfpbr chart uses full tiles)")
    comments.append(f"reproduce: sdfpbr chart --spec {case.index:05d}-{case.kind}.toml --hdr out.npy")
    path = Path(directory) / f"{case.index:05d}-{case.kind}.toml"
    with atomic_file(path) as f:
        f.write(spec_to_toml(case.spec, comments).encode())
    return path
