"""The machine's own solids along the program (docs/MATH.md §16): every pair of solids that may
meet (one on the work's side: the bed, the table's links, the part, the stock, the fixtures;
one on the tool's side: a column moving with the linear axes, the ram, the head's links, the
spindle, the tool) at every pose the machine passes through, its joints and X Y Z linear along
each move (with or without tool-centre-point control), as the check computes the motion
(`checker.verify.ProgramMotion`). The tool against the part, the stock and the fixtures is the
part's and the stock's check, not repeated here.

Broad phase: each solid's bounding sphere, and from a pose measured exactly its distance less
the travel between (docs/MATH.md §16.4); a pose is measured (coal, the narrow phase) only where
those lower bounds leave a finding, the pair's least distance or its moves' certification
open. Between poses, conservative advancement: over a stretch of a move on which no point of either
solid travels more than L (`checker.collide.placement`), with distances da and db at its ends,
no pose is closer than (da + db - L) / 2; a stretch whose bound is below the clearance is
halved until certified, or its contact found, the contact's start located to `T_PRECISION` of
the move, or until no point travels more than `RESOLUTION` on it (then nothing on it is closer
than the nearer end's distance less RESOLUTION / 2: a contact shallower than that below the
clearance, found nowhere at a checked pose, is the one thing that can pass); near each pair's
least distance the stretches are halved until it is found to `PRECISION` (the near-miss
listing). mm, degrees."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from checker import verdict as vd
from checker.collide.placement import Links, Rigid
from checker.collide.solids import Solid, machine_solids, tool_solid, work_solids
from checker.moves import START
from checker.progress import step
from checker.results import MachineFinding, MachinePair, MachineResult, VerdictCounts

HORIZON = 5.0  # mm beyond the clearance: along a move, farther spheres are measured exactly
# only where their gap is below the pair's least distance
PRECISION = 0.005  # mm: a pair's least distance is found to this (or 1 % of it)
T_PRECISION = 1e-5  # of a move: where a contact starts
RESOLUTION = 0.005  # mm: a stretch on which no point travels farther is not halved again
_MAX_ROUNDS = 40
DEFAULT_CLEARANCE = 1.0  # mm


@dataclass(frozen=True)
class MachineMoves:
    """Per pose: program `xyz (P, 3)` (machine X Y Z, or the work-frame tip with `tcp`), rotary
    `joints (P, k)` (deg), `op (P,)`, `gauge (P,)` the spindle nose's height above the tip (mm),
    `start (P,)` poses no move reaches."""

    xyz: np.ndarray
    joints: np.ndarray
    tcp: bool
    op: np.ndarray
    gauge: np.ndarray
    start: np.ndarray


def gauge_length(cutter, tool_length: float) -> float:
    """The spindle nose above the tool tip (mm): the machine's `tool_length` when it states one
    (head machines posted without TCP), else the cutter's stickout plus its holder, else its
    stickout, else the top of its body as the check models it (its flute length or length, at
    least four diameters)."""
    if tool_length > 0.0:
        return float(tool_length)
    s, hl = cutter.stickout, cutter.holder_length
    if s is not None and hl:
        return float(s) + float(hl)
    if s:
        return float(s)
    return max(float(cutter.flute_length or 0.0), float(cutter.H or 0.0), 4.0 * float(cutter.d))


def machine_moves(machine, motion, lines: np.ndarray, cutters: dict, path: str | None,
                  tolerance: float) -> MachineMoves:
    """The program positions of `motion`'s poses on `machine`: its own (`motion.path`) when
    the check ran the joints linearly, else the words the post would choose for the poses'
    axes (`checker.five_axis.machine_motion.MachineMotion`)."""
    from checker.five_axis.machine_motion import MachineMotion
    from checker.postproc.kinematics import Chain

    moves = motion.moves
    op = np.asarray(motion.op_of)
    chain = Chain(machine)
    if motion.path is not None:
        p = motion.path
        xyz, joints, tcp = p.xyz, p.joints, bool(p.motion.tcp)
    else:
        tcp = bool(machine.tcp.enabled)
        mm = MachineMotion(chain, tcp, tolerance, frozenset())
        joints = (mm.joints(moves.axis, lines, path) if chain.k else
                  np.zeros((len(moves), 0)))
        xyz = np.asarray(chain.inverse_position(moves.tip, joints, tcp), float)
    g = {o: gauge_length(cutters[o], float(machine.head.tool_length)) for o in cutters}
    gauge = np.array([g.get(int(o), 0.0) for o in op])
    return MachineMoves(np.asarray(xyz, float), np.asarray(joints, float), tcp, op, gauge,
                        moves.kind == START)


class Scene:
    """The solids and the pairs to check, placed at any pose of the moves (`at`)."""

    def __init__(self, solids: list[Solid], links: Links, mv: MachineMoves) -> None:
        self.solids, self.links, self.mv = solids, links, mv
        work = [i for i, s in enumerate(solids) if s.side == "work"]
        tool = [i for i, s in enumerate(solids) if s.side == "tool"]
        self.pairs = [(a, b) for a in work for b in tool
                      if not (solids[b].kind == "tool" and solids[a].kind != "machine")
                      and not (solids[a].link == ("table", 0) == solids[b].link)]
        self.ops = sorted(set(int(o) for o in np.unique(mv.op)))

    def state(self, end: np.ndarray, t: np.ndarray):
        """(xyz, joints, op, gauge) at fraction `t` of the moves ending at poses `end`."""
        mv, a = self.mv, end - 1
        tt = t[:, None]
        xyz = mv.xyz[end] - (1.0 - tt) * (mv.xyz[end] - mv.xyz[np.maximum(a, 0)])
        joints = mv.joints[end] - (1.0 - tt) * (mv.joints[end] - mv.joints[np.maximum(a, 0)])
        return xyz, joints, mv.op[end], mv.gauge[end]

    def place(self, xyz, joints, op, gauge, only=None) -> list[Rigid | None]:
        """Per solid its link's placement at the states (the solid's own frame: the spindle
        frame moved up by the gauge, the part frame through the setup); `only` the solids to
        place (None: all)."""
        X = self.links.machine_x(xyz, joints, self.mv.tcp)
        table, head = self.links.place(X, joints)
        n = len(X)
        setup = Rigid(np.broadcast_to(self.links.setup.R[0], (n, 3, 3)),
                      np.broadcast_to(self.links.setup.t[0], (n, 3)))
        out: list[Rigid | None] = []
        for i, s in enumerate(self.solids):
            if only is not None and i not in only:
                out.append(None)
                continue
            side, j = s.link
            if side == "table":
                P = table[j]
                if s.kind != "machine":
                    P = P.then(setup)
                if s.moves.any():
                    P = Rigid(P.R, P.t + X * s.moves)
            else:
                P = head[j]
                if s.gauge:
                    P = P.shifted(np.column_stack([np.zeros(n), np.zeros(n), gauge]))
            out.append(P)
        return out

    def shape_table(self, s: Solid, op: np.ndarray):
        """(centre (N, 3), radius (N,), present (N,)) of solid `s` per state's operation."""
        n = len(op)
        c, r = np.zeros((n, 3)), np.full(n, np.nan)
        for o in self.ops:
            sh = s.shape(o)
            if sh is not None:
                sel = op == o
                c[sel], r[sel] = sh.center, sh.radius
        return c, r, np.isfinite(r)


class Distances:
    """Exact distances between the pairs' solids through coal, counted: one distance functor
    per pair of geometries (it keeps the GJK's last guess) and two placements set in place."""

    def __init__(self, scene: Scene) -> None:
        import coal

        self.coal, self.scene, self.count = coal, scene, 0
        self.req, self.res = coal.DistanceRequest(), coal.DistanceResult()
        self.Ta, self.Tb = coal.Transform3s(), coal.Transform3s()
        self.functors: dict = {}

    def _functor(self, ga, gb):
        key = (id(ga), id(gb))
        f = self.functors.get(key)
        if f is None:
            f = self.functors[key] = self.coal.ComputeDistance(ga, gb)
        return f

    def __call__(self, a: Solid, b: Solid, Pa: Rigid, Pb: Rigid, op: np.ndarray) -> np.ndarray:
        """(N,) mm between solids a and b placed by Pa, Pb (already taken at the N states)."""
        out = np.full(len(op), np.inf)
        req, res, Ta, Tb = self.req, self.res, self.Ta, self.Tb
        for o in np.unique(op):
            sa, sb = a.shape(int(o)), b.shape(int(o))
            if sa is None or sb is None:
                continue
            rows = np.flatnonzero(op == o)
            Ra, ta = Pa.R[rows] @ sa.R0, np.einsum("nij,j->ni", Pa.R[rows], sa.t0) + Pa.t[rows]
            Rb, tb = Pb.R[rows] @ sb.R0, np.einsum("nij,j->ni", Pb.R[rows], sb.t0) + Pb.t[rows]
            f = self._functor(sa.geom, sb.geom)
            got = np.empty(len(rows))
            for i in range(len(rows)):  # the narrow phase: one library call per pair and pose
                Ta.setRotation(Ra[i])
                Ta.setTranslation(ta[i])
                Tb.setRotation(Rb[i])
                Tb.setTranslation(tb[i])
                res.clear()
                got[i] = f(Ta, Tb, req, res)
            out[rows] = got
            self.count += len(rows)
        return out


def _distances(scene: Scene, dist: Distances, places: list[Rigid], op: np.ndarray,
               pair_of: np.ndarray, row_of: np.ndarray, limit: np.ndarray):
    """(Q,) distances of pairs `pair_of (Q,)` at state rows `row_of (Q,)` of `places` (per
    solid, None: not placed): exact where the spheres' gap is below `limit (Q,)`, else the
    gap (a lower bound); and (Q,) whether each is exact."""
    out = np.full(len(pair_of), np.inf)
    exact = np.zeros(len(pair_of), bool)
    for p in np.unique(pair_of):
        ia, ib = scene.pairs[int(p)]
        a, b = scene.solids[ia], scene.solids[ib]
        q = np.flatnonzero(pair_of == p)
        rows = row_of[q]
        o = op[rows]
        ca, ra, ha = scene.shape_table(a, o)
        cb, rb, hb = scene.shape_table(b, o)
        Pa, Pb = places[ia].take(rows), places[ib].take(rows)
        gap = np.linalg.norm(Pa.apply(ca) - Pb.apply(cb), axis=1) - ra - rb
        gap = np.where(ha & hb, gap, np.inf)
        near = gap < limit[q]
        out[q] = gap
        if near.any():
            k = np.flatnonzero(near)
            out[q[k]] = dist(a, b, Pa.take(k), Pb.take(k), o[k])
            exact[q[k]] = True
    return out, exact


def _speeds(scene: Scene, end: np.ndarray) -> np.ndarray:
    """(S, M) per solid the speed bound of its points along the moves ending at `end`."""
    mv, links = scene.mv, scene.links
    a = end - 1
    turn = np.radians(np.abs(mv.joints[end] - mv.joints[a]))
    xs = links.x_speed(mv.xyz, mv.joints, a, end, mv.tcp)
    op = mv.op[end]
    out = np.zeros((len(scene.solids), len(end)))
    setup_R, setup_t = links.setup.R[0], links.setup.t[0]
    for si, s in enumerate(scene.solids):
        side, j = s.link
        for o in scene.ops:
            sh = s.shape(o)
            sel = op == o
            if sh is None or not sel.any():
                continue
            if side == "table":
                c = sh.center if s.kind == "machine" else setup_R @ sh.center + setup_t
                v = xs[sel] if s.moves.any() else np.zeros(sel.sum())
                if j:
                    arm = np.linalg.norm(c - links.pivot("table", j)) + sh.radius
                    v = v + turn[sel] @ links.table_arms(j, arm)
            else:
                g = np.array([0.0, 0.0, float(mv.gauge[end][sel][0])]) if s.gauge else np.zeros(3)
                v = xs[sel]
                if j:
                    arm = np.linalg.norm(sh.center + g - links.pivot("head", j)) + sh.radius
                    v = v + turn[sel] @ links.head_arms(j, arm)
            out[si, sel] = v
    return out


@dataclass
class Contacts:
    """Contacts found: pair, pose the move reaches, t along it (1: the pose), distance."""

    pair: list
    end: list
    t: list
    d: list


def check_machine(machine, motion, cutters: dict, job, *, clearance: float = DEFAULT_CLEARANCE,
                  stock=None, fixtures=(), tolerance: float = 1e-3) -> MachineResult:
    """The machine's solids, the tool and the work along `motion` (`checker.verify.
    ProgramMotion`) on `machine` (with components), the operations' `cutters`; `job` gives the
    lines (`job.m`), the part's triangles (None: no part), `stock` a resolved stock shape
    (`checker.stock.spec`) or None, `fixtures` (`checker.stock.fixtures.Fixture`)."""
    from checker.collide.solids import stock_shape
    from checker.postproc.kinematics import Chain

    t0 = time.perf_counter()
    moves = motion.moves
    lines = job.m.line[moves.row]
    mv = machine_moves(machine, motion, lines, cutters, str(job.apt_path), tolerance)
    chain = Chain(machine)
    links = Links(chain)
    solids = (machine_solids(machine, job.cfg) + tool_solid(cutters, len(chain.head))
              + work_solids(getattr(job, "triangles", None),
                            None if stock is None else stock_shape(stock), fixtures,
                            len(chain.table)))
    scene = Scene(solids, links, mv)
    dist = Distances(scene)
    n, npair = len(moves), len(scene.pairs)
    idx = np.arange(n)
    ends = np.flatnonzero(~mv.start & (idx > 0))
    speed = _speeds(scene, ends)
    with step("machine: the solids at every pose"):
        places = scene.place(mv.xyz, mv.joints, mv.op, mv.gauge)
        d_pose, exact, best = _at_poses(scene, dist, places, mv, ends, speed, clearance)
    contacts = Contacts([], [], [], [])
    best_t = {p: (int(np.argmin(np.where(exact[p], d_pose[p], np.inf))), 1.0)
              for p in range(npair)}
    with step("machine: along the moves") as advance:
        _along(scene, dist, d_pose, ends, speed, clearance, best, best_t, contacts, advance)
    result = _result(machine, scene, mv, moves, job, d_pose, contacts, best, best_t, clearance,
                     dist.count)
    result.time_s = time.perf_counter() - t0
    return result


STRIDES = (64, 16, 4, 1)  # the poses measured exactly first, then between them


def _at_poses(scene: Scene, dist: Distances, places: list[Rigid], mv: MachineMoves,
              ends: np.ndarray, speed: np.ndarray, clearance: float):
    """Per pair and pose a distance that is exact where it matters and a lower bound elsewhere
    (docs/MATH.md §16.4): `(d (pairs, P), exact (pairs, P), best (pairs,))`, `best` each pair's
    least distance over the poses (exact). The lower bounds are the spheres' gap and, from a
    pose measured exactly, its distance less the travel bound L of the moves between them (no
    point of the two solids moves farther). Poses are measured every `STRIDES[0]`-th first,
    then every `STRIDES[k]`-th where the bound is below the need: the larger of the clearance
    and the pair's least distance so far, plus the travel of the moves at the pose (so that
    the conservative advancement certifies them at once)."""
    n, npair = len(mv.op), len(scene.pairs)
    idx = np.arange(n)
    seg = np.cumsum(mv.start | (idx == 0))  # the moves between poses of one segment
    d = np.full((npair, n), np.inf)
    exact = np.zeros((npair, n), bool)
    best = np.full(npair, np.inf)
    for p, (ia, ib) in enumerate(scene.pairs):
        lb = _gaps(scene, places, mv.op, ia, ib)
        present = np.isfinite(lb)
        if not present.any():
            continue
        into = np.zeros(n)  # the travel bound of the move reaching each pose
        into[ends] = speed[ia] + speed[ib]
        step_l = np.maximum(into, np.r_[into[1:], 0.0])  # of the moves into and out of it
        C = np.cumsum(into)
        ex = exact[p]
        for stride in STRIDES:
            need = np.maximum(clearance, best[p]) + step_l
            on = (idx % stride == 0) | (seg != np.r_[-1, seg[:-1]]) if stride > 1 else True
            cand = np.flatnonzero(on & present & ~ex & (lb < need))
            if cand.size == 0:
                continue
            lb[cand] = dist(scene.solids[ia], scene.solids[ib], places[ia].take(cand),
                            places[ib].take(cand), mv.op[cand])
            ex[cand] = True
            best[p] = min(best[p], float(lb[cand].min()))
            lb = np.maximum(lb, _from_measured(lb, ex, C, seg))
        d[p] = lb
    return d, exact, best


def _from_measured(d: np.ndarray, exact: np.ndarray, C: np.ndarray,
                   seg: np.ndarray) -> np.ndarray:
    """(P,) the lower bound at every pose from the nearest pose measured exactly before and
    after it in its segment: its distance less the travel between them (`C` the cumulative
    travel bound); -inf where there is none."""
    n = len(d)
    idx = np.arange(n)
    left = np.maximum.accumulate(np.where(exact, idx, -1))
    right = np.minimum.accumulate(np.where(exact, idx, n)[::-1])[::-1]
    lc, rc = np.maximum(left, 0), np.minimum(right, n - 1)
    from_l = np.where((left >= 0) & (seg[lc] == seg), d[lc] - (C - C[lc]), -np.inf)
    from_r = np.where((right < n) & (seg[rc] == seg), d[rc] - (C[rc] - C), -np.inf)
    return np.maximum(from_l, from_r)


def _gaps(scene: Scene, places: list[Rigid], op: np.ndarray, ia: int, ib: int) -> np.ndarray:
    """(P,) the gap between the bounding spheres of solids ia and ib at every pose (a lower
    bound of their distance; inf where either is absent for the pose's operation)."""
    a, b = scene.solids[ia], scene.solids[ib]
    ca, ra, ha = scene.shape_table(a, op)
    cb, rb, hb = scene.shape_table(b, op)
    gap = np.linalg.norm(places[ia].apply(ca) - places[ib].apply(cb), axis=1) - ra - rb
    return np.where(ha & hb, gap, np.inf)


def _along(scene, dist, d_pose, ends, speed, clearance, best, best_t, contacts, advance):
    """Conservative advancement over every pair and move (module docstring)."""
    npair = len(scene.pairs)
    if ends.size == 0 or npair == 0:
        return
    m = len(ends)
    P = np.repeat(np.arange(npair), m)
    K = np.tile(np.arange(m), npair)
    A = np.array([a for a, _ in scene.pairs])
    B = np.array([b for _, b in scene.pairs])
    L = speed[A][:, :] + speed[B]  # (pairs, M)
    t0, t1 = np.zeros(P.size), np.ones(P.size)
    d0, d1 = d_pose[P, ends[K] - 1], d_pose[P, ends[K]]
    for _ in range(_MAX_ROUNDS):
        travel = (t1 - t0) * L[P, K]
        lb = 0.5 * (d0 + d1 - travel)
        in0, in1 = d0 < clearance, d1 < clearance
        width = t1 - t0
        slack = np.maximum(PRECISION, 0.01 * np.abs(best[P]))
        open_ = (((lb < clearance) & ~in0 & ~in1 & (travel > RESOLUTION))
                 | ((in0 != in1) & (width > T_PRECISION) & (travel > RESOLUTION))
                 | ((lb < best[P] - slack) & ~(in0 & in1) & (travel > slack)))
        P, K, t0, t1, d0, d1 = P[open_], K[open_], t0[open_], t1[open_], d0[open_], d1[open_]
        if P.size == 0:
            break
        tm = 0.5 * (t0 + t1)
        e = ends[K]
        dm, exact = np.empty(P.size), np.zeros(P.size, bool)
        for p in np.unique(P):
            q = np.flatnonzero(np.equal(P, p))
            xyz, joints, op, gauge = scene.state(e[q], tm[q])
            places = scene.place(xyz, joints, op, gauge, only=set(scene.pairs[int(p)]))
            limit = np.full(q.size, max(clearance + HORIZON, best[int(p)]))
            dm[q], exact[q] = _distances(scene, dist, places, op, P[q], np.arange(q.size),
                                         limit)
        advance(1)
        hit = np.flatnonzero(dm < clearance)
        contacts.pair += P[hit].tolist()
        contacts.end += e[hit].tolist()
        contacts.t += tm[hit].tolist()
        contacts.d += dm[hit].tolist()
        for p in np.unique(P):  # the least distances: exact ones only (a gap is a bound)
            q = np.flatnonzero(np.equal(P, p) & exact)
            if q.size == 0:
                continue
            k = q[np.argmin(dm[q])]
            if dm[k] < best[p]:
                best[p] = dm[k]
                best_t[int(p)] = (int(e[k]), float(tm[k]))
        P, K = np.r_[P, P], np.r_[K, K]
        t0, t1 = np.r_[t0, tm], np.r_[tm, t1]
        d0, d1 = np.r_[d0, dm], np.r_[dm, d1]


def _axes(machine, xyz: np.ndarray, joints: np.ndarray) -> dict[str, float]:
    out = {a: round(float(v), 6) for a, v in zip("XYZ", xyz, strict=True)}
    for ax, v in zip(machine.rotary_axes, joints, strict=True):
        out[ax.name] = round(float(v), 6)
    return out


def _result(machine, scene: Scene, mv: MachineMoves, moves, job, d_pose, contacts: Contacts,
            best, best_t, clearance: float, count: int) -> MachineResult:
    """Findings (a run of consecutive poses in contact per pair: its first contact), the
    verdicts per pose and the near-miss listing."""
    n, m = len(moves), job.m
    npair = len(scene.pairs)
    first_t = np.full((npair, n), np.inf)  # per pair and pose: where along its move it starts
    least = d_pose.copy()
    inpose = d_pose < clearance
    first_t[inpose] = 1.0
    for p, e, t, d in zip(contacts.pair, contacts.end, contacts.t, contacts.d, strict=True):
        first_t[p, e] = min(first_t[p, e], t)
        least[p, e] = min(least[p, e], d)
    touched = np.isfinite(first_t)
    verdict = vd.decide_machine(np.where(touched, least, np.inf).min(axis=0, initial=np.inf),
                                clearance)
    findings = []
    for p in range(npair):
        rows = np.flatnonzero(touched[p])
        if rows.size == 0:
            continue
        runs = np.split(rows, np.flatnonzero(np.diff(rows) > 1) + 1)
        a, b = (scene.solids[i].name for i in scene.pairs[p])
        for run in runs:
            e = int(run[0])
            t = float(first_t[p, e])
            xyz, joints, _, _ = scene.state(np.array([e]), np.array([t]))
            row = int(moves.row[e])
            findings.append(MachineFinding(
                index=0, verdict="machine", a=a, b=b, move=row, line=int(m.line[row]),
                op=int(m.op[row]), t=t, axes=_axes(machine, xyz[0], joints[0]),
                distance=float(least[p, run].min()), poses=int(run.size)))
    findings.sort(key=lambda f: (f.move, f.t))
    for i, f in enumerate(findings):
        f.index = i
    pairs = []
    for p in range(npair):
        if not np.isfinite(best[p]):
            continue
        e, t = best_t[p]
        xyz, joints, _, _ = scene.state(np.array([e]), np.array([t]))
        a, b = (scene.solids[i].name for i in scene.pairs[p])
        pairs.append(MachinePair(a=a, b=b, least=float(best[p]),
                                 line=int(m.line[moves.row[e]]),
                                 axes=_axes(machine, xyz[0], joints[0])))
    pairs.sort(key=lambda q: q.least)
    counts = VerdictCounts(ok=int((verdict == "ok").sum()),
                           machine=int((verdict == "machine").sum()))
    return MachineResult(machine=machine.name, source=machine.components_source or "not stated",
                         clearance=clearance, solids=[s.name for s in scene.solids],
                         pairs=npair, counts=counts, findings=findings, near_misses=pairs,
                         distances=count)
