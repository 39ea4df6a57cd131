"""A stand-in DEM engine: a real executable that demcal drives like LIGGGHTS or Yade.

It is NOT a simulation. It reads its filled input file (``key = value`` lines, ``#``
comments), computes a planted angle of repose that depends smoothly on the contact
parameters, and writes a cone of spheres of that angle (plus seeded noise) as
``x,y,z,radius`` CSV in metres, the way a real engine's export would leave the settled
pile. demcal then measures the cone as it measures its own piles.

    python engine.py input.txt

Planted angle (deg), with mu = pp.static_friction, mur = pp.rolling_friction and
muw = pw.static_friction:

    aor = 30 + 15 (mu - 0.6) - 10 (mu - 0.6)^2 + 25 (mur - 0.2) + 2 (muw - 0.55)
          + noise_deg * N(0, 1)          (seeded by the input's seed)

Input keys besides the parameters: ``seed``, ``output`` (the CSV file), ``noise_deg``,
``sleep_s`` (wall time of a "run"), ``base_radius`` and ``sphere_radius`` (m), and ``mode``:
``ok``; ``crash`` (exit code 3); ``silent`` (exit 0, no output); ``hang`` (sleep forever);
``garbage`` (an unreadable CSV). ``fail_flag`` (a path): crash while that file exists;
``hang_if`` (``VALUE > LIMIT``): hang when it holds. Only the standard library is used.
"""

from __future__ import annotations

import math
import os
import random
import sys
import time


def read_input(path: str) -> dict[str, str]:
    """``key = value`` lines of the input file."""
    out = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                key, _, value = line.partition("=")
                out[key.strip()] = value.strip()
    return out


def planted_aor(mu: float, mur: float, muw: float) -> float:
    """The noise-free angle of repose, deg."""
    return 30 + 15 * (mu - 0.6) - 10 * (mu - 0.6) ** 2 + 25 * (mur - 0.2) + 2 * (muw - 0.55)


def cone(angle_deg: float, base_radius: float, r: float, rng: random.Random) -> list[tuple]:
    """Spheres on the surface of a cone (and its base) standing on z = 0, m."""
    tan = math.tan(math.radians(angle_deg))
    height = base_radius * tan
    spheres = []
    step = 1.2 * r
    n_rings = max(2, int(height / (step * math.sin(math.atan(tan)))))
    for k in range(n_rings + 1):
        z = height * k / n_rings
        rho = base_radius - z / tan
        n = max(1, int(2 * math.pi * rho / step))
        phase = rng.uniform(0, 2 * math.pi)
        for i in range(n):
            a = phase + 2 * math.pi * i / n
            jitter = rng.uniform(-0.15, 0.15) * r
            spheres.append(((rho + jitter) * math.cos(a), (rho + jitter) * math.sin(a),
                            z + r))
    rho = base_radius - 2 * step
    while rho > step:  # the base disc under the cone
        n = int(2 * math.pi * rho / step)
        for i in range(n):
            a = 2 * math.pi * i / n
            spheres.append((rho * math.cos(a), rho * math.sin(a), r))
        rho -= 2 * step
    return [(x, y, z, r) for x, y, z in spheres]


def effective_mode(cfg: dict[str, str]) -> str:
    """The input's ``mode``, turned into ``crash`` by an existing ``fail_flag`` file and into
    ``hang`` by a ``hang_if`` (``VALUE > LIMIT``) that holds."""
    mode = cfg.get("mode", "ok")
    flag = cfg.get("fail_flag")
    if flag and os.path.exists(flag):
        mode = "crash"
    if cfg.get("hang_if"):
        value, _, limit = cfg["hang_if"].partition(">")
        if float(value) > float(limit):
            mode = "hang"
    return mode


def write_pile(cfg: dict[str, str], output: str) -> None:
    """Write the cone of the planted angle (plus seeded noise) as ``x,y,z,radius`` CSV, m."""
    rng = random.Random(int(cfg["seed"]))
    mu = float(cfg["pp.static_friction"])
    mur = float(cfg["pp.rolling_friction"])
    muw = float(cfg["pw.static_friction"])
    aor = planted_aor(mu, mur, muw) + float(cfg.get("noise_deg", "0.3")) * rng.gauss(0, 1)
    aor = min(max(aor, 5.0), 80.0)
    spheres = cone(aor, float(cfg.get("base_radius", "0.05")),
                   float(cfg.get("sphere_radius", "0.002")), rng)
    with open(output, "w") as f:
        f.write("x,y,z,radius\n")
        for s in spheres:
            f.write(",".join(repr(v) for v in s) + "\n")
    print(f"planted angle {aor:.3f} deg; wrote {len(spheres)} spheres to {output}")


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: engine.py INPUT", file=sys.stderr)
        return 2
    cfg = read_input(argv[1])
    print(f"stand-in engine: input {argv[1]}, mode {cfg.get('mode', 'ok')}, "
          f"seed {cfg.get('seed')}")
    time.sleep(float(cfg.get("sleep_s", "0")))
    mode = effective_mode(cfg)
    if mode == "crash":
        print("ERROR: the stand-in engine crashed on purpose", file=sys.stderr)
        return 3
    if mode == "hang":
        while True:
            time.sleep(1)
    if mode == "silent":
        return 0
    output = cfg.get("output", "pile.csv")
    if mode == "garbage":
        with open(output, "w") as f:
            f.write("x,y,z,radius\n1,2,three,4\n")
        return 0
    write_pile(cfg, output)
    return 0

if __name__ == "__main__":
    sys.exit(main(sys.argv))
