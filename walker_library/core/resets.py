"""Reset maps of a heel strike: the relabelling of coordinates and the rigid plastic impact.

* :class:`Relabel` — the linear (affine) map of :attr:`~.hybrid.WalkerSpec.relabel` on a state
  and its modes: position coordinates q' = A q + b (a signed permutation for a symmetric walker),
  the multibody's joint rates by the same map v' = A_mb v, the modes by theirs.
* :func:`floating_model` — the multibody of a model pinned at its root (a revolute joint from
  the world at the stance foot) with the pin released: a massless base body on a translational
  x/z joint between the world and the root joint, so that the root can move.
* :class:`ImpactMap` — the plastic impact of a rigid walker at heel strike
  (:func:`porthamiltonian.simulation.impact.model_impact` on the floating model: the striking
  point stops, the old pin is free; the multibody's active constraints, a locked knee, stay
  satisfied: their rows join the impact), followed by the relabelling that re-pins the model at
  the striking point. The state is mapped, the mode parameters are the rule's business.
* :class:`ConstraintImpact` — the plastic impact onto a constraint of the walker's multibody
  (a knee strike onto the knee's lock: :func:`porthamiltonian.simulation.switching.impact_onto`),
  no relabelling; the rule sets the constraint's switch.

The maps are functions of the state with a Jacobian for saltation-matrix computations
(:meth:`Relabel.matrix`, exact; the impacts' ``jacobian`` from their ``tangents``: for
:class:`ConstraintImpact` fourth-order differences of the whole impact along each column).
:meth:`ImpactMap.tangents` is the impact's forward-mode derivative by the state and the
parameters: with v = M⁻¹p, the floating state (q_f = F q, the hip's position y_h(q) and velocity
J_h(q) v), the saddle-point system

    K(q_f) [v⁺; −Λ] = [M_f v_f; 0],   K = [[M_f, Gᵀ], [G, 0]]

(G: the striking point's rows and those of the active constraints),

and the momenta after the relabelling p' = M(q', p_after) v', the linear solves are
differentiated exactly (d(K⁻¹b) = K⁻¹(db − dK K⁻¹b): K [dv⁺; −dΛ] = [dM_f (v_f − v⁺) + dGᵀΛ +
M_f dv_f; −dG v⁺], one factorisation for all columns); the matrices' and outputs' own
derivatives (dM u, dG u, dy_h, dJ_h v at fixed vectors u, v) by fourth-order differences of the
compiled functions along each column (:func:`porthamiltonian.simulation.differences.directional`:
~1e-12 relative; the code generator has no derivatives of named matrices): at most six
evaluations of each (cheap) matrix function per column, two along what it does not read (the
momenta, the slope, the stance foot's position), instead of four impacts.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from porthamiltonian.modeling.expressions import parse
from porthamiltonian.simulation.assembly import constraint_rows
from porthamiltonian.simulation.compiled import CompiledModel
from porthamiltonian.simulation.differences import directional

if TYPE_CHECKING:
    from porthamiltonian.modeling.model import Model, ModelDescription

__all__ = ["PIN", "ConstraintImpact", "Floating", "ImpactMap", "Relabel", "floating_model"]

#: name of the translational joint (and its base body) that :func:`floating_model` inserts
PIN = "pin"


def _frozen(a: Any) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Relabel:
    """The relabelling of a walker's coordinates (see the module docstring).

    positions : state indices of the position-like coordinates the map acts on (every state but
        the multibody momenta); A, b : the map on them. coordinates : indices into ``positions``
        of the multibody coordinates, in the multibody's order (their rates map with A
        restricted to them). modes : parameter indices of the modes; B, c : their map.
    b_outputs, c_outputs : (row, output index) of offsets that depend on parameters (e.g. one
        spoke's angle, 2 pi / n_spokes): added from the model's outputs ``y``.
    """

    positions: tuple[int, ...]
    A: np.ndarray
    b: np.ndarray
    coordinates: tuple[int, ...]
    modes: tuple[int, ...]
    B: np.ndarray
    c: np.ndarray
    b_outputs: tuple[tuple[int, int], ...] = ()
    c_outputs: tuple[tuple[int, int], ...] = ()

    @classmethod
    def build(cls, space: Sequence[str], A: Sequence[Sequence[float]],
              b: Sequence[float | str], state_names: Sequence[str], param_names: Sequence[str],
              coordinates: Sequence[str], output_of: Mapping[str, int]) -> Relabel:
        """From a plan's :class:`~.plan.RelabelMap` (names of the map's space, its rows and
        offsets: numbers, or the names of the outputs that evaluate them) and the compiled
        model's layout; ``coordinates``: the multibody's coordinate states in order;
        ``output_of``: the index of each output."""
        a = np.asarray(A, dtype=float)
        pos = [i for i, n in enumerate(space) if n in state_names]
        mod = [i for i, n in enumerate(space) if n not in state_names]
        where = {space[i]: k for k, i in enumerate(pos)}

        def split(rows: list[int]) -> tuple[np.ndarray, tuple[tuple[int, int], ...]]:
            """Numeric offsets of ``rows`` (0 where an expression) and the expressions' outputs."""
            const = [0.0 if isinstance(b[i], str) else float(b[i]) for i in rows]
            outs = tuple((k, output_of[v]) for k, v in enumerate(b[i] for i in rows)
                         if isinstance(v, str))
            return _frozen(const), outs

        b_pos, b_out = split(pos)
        c_mod, c_out = split(mod)
        return cls(tuple(state_names.index(space[i]) for i in pos), _frozen(a[np.ix_(pos, pos)]),
                   b_pos, tuple(where[c] for c in coordinates),
                   tuple(param_names.index(space[i]) for i in mod),
                   _frozen(a[np.ix_(mod, mod)]), c_mod, b_out, c_out)

    def matrix(self) -> np.ndarray:
        """A (the Jacobian of the map on the position coordinates)."""
        return self.A

    @staticmethod
    def _offsets(const: np.ndarray, outs: tuple[tuple[int, int], ...],
                 y: np.ndarray) -> np.ndarray:
        b = const.copy()
        for k, o in outs:
            b[k] += y[o]
        return b

    def state(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``x`` with its position coordinates mapped (momenta untouched: see :meth:`rates`);
        ``y``: the model's outputs (for offsets that depend on parameters)."""
        out = np.array(x, dtype=float)
        idx = list(self.positions)
        out[idx] = self.A @ out[idx] + self._offsets(self.b, self.b_outputs, y)
        return out

    def rates(self, v: np.ndarray) -> np.ndarray:
        """The multibody's joint rates mapped: v' = A_mb v."""
        r = list(self.coordinates)
        return self.A[np.ix_(r, r)] @ np.asarray(v, dtype=float)

    def params(self, p: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The parameter vector with its modes mapped."""
        out = np.array(p, dtype=float)
        idx = list(self.modes)
        if idx:
            out[idx] = self.B @ out[idx] + self._offsets(self.c, self.c_outputs, y)
        return out


def _shifted(value: Sequence[Any], by: Sequence[Any]) -> list:
    """A 3-vector of numbers/expressions minus ``by`` (component-wise, as expressions)."""
    return [v if b == 0 else f"({v}) - ({b})" for v, b in zip(value, by)]


def _offset(joints: dict, bodies: dict, point: str, root_body: str) -> list | None:
    """Position of ``point`` in ``root_body``'s frame when the point's body is welded to it
    (through weld joints only), else None."""
    body = next((b for b, d in bodies.items() if point in (d.get("points") or {})), None)
    if body is None:
        return None
    total = list(bodies[body]["points"][point])
    while body != root_body:
        joint = next((j for j in joints.values() if j.get("child") == body), None)
        if joint is None or joint.get("type") != "weld":
            return None
        total = [f"({a}) + ({b})" if b != 0 else a
                 for a, b in zip(total, joint.get("origin", [0, 0, 0]))]
        body = joint["parent"]
    return total


def _is_zero(vector: Sequence[Any], params: Iterable[str]) -> bool:
    """Whether a joint origin (numbers, or expressions in ``params``) is zero."""
    import sympy as sp

    names = {n: sp.Symbol(n, real=True) for n in params}
    return all(v == 0 if isinstance(v, (int, float)) else parse(v, names, "joint origin") == 0
               for v in vector)


@dataclass(frozen=True)
class Floating:
    """:func:`floating_model`'s result: the model, the root joint, and the joints re-hung from
    the free base (their coordinates become absolute: ψ = q + q_root)."""

    model: Model
    root: str
    rehung: tuple[str, ...]


def floating_model(model: ModelDescription, multibody: str, root: str, about: str) -> Floating:
    """The multibody of ``model`` (a frozen description; the multibody alone, same parameters)
    with its pinned root joint ``root``
    (a revolute joint from the world) released, for the impact map.

    A massless base body on a translational x/z joint :data:`PIN` carries the root body at the
    point ``about`` (the hip; a point of the root body or of a body welded to it): the root body's
    frame is moved there, and its revolute joint hangs from the base. Revolute joints of the root
    body at that point about the same axis (the other leg at the hip) are re-hung from the base
    too, so that every leg's coordinate is an absolute angle. Coordinates: ``<mb>.q.pin.x``,
    ``<mb>.q.pin.z`` (the position of ``about``), then the original ones (absolute for the
    re-hung joints); a point ``pin_point`` marks the released pin.

    This is the floating base of Goswami et al. and Garcia et al.'s impact equations: with light
    legs (Garcia's mass ratio 1e-9) the angular momentum of the trailing leg about the hip is then
    one coordinate's momentum, which the impact leaves exactly unchanged, instead of a difference
    of large numbers that loses nine digits."""
    comp = model.components[multibody]
    bodies = {k: dict(v) for k, v in comp.value("bodies").items()}
    joints = {k: dict(v) for k, v in comp.value("joints").items()}
    root_body = joints[root]["child"]
    shift = _offset(joints, bodies, about, root_body) or [0, 0, 0]
    body = bodies[root_body]
    body["com"] = _shifted(body.get("com", [0, 0, 0]), shift)
    for key in ("points", "frames", "world_frames"):
        if body.get(key):
            body[key] = {k: _shifted(v, shift) for k, v in body[key].items()}
    body["points"] = {**(body.get("points") or {}),
                      f"{PIN}_point": _shifted([0, 0, 0], shift)}
    base = f"{PIN}_base"
    rehung = []
    for name, joint in joints.items():
        if joint.get("parent") != root_body:
            continue
        origin = _shifted(joint.get("origin", [0, 0, 0]), shift)
        joints[name] = {**joint, "origin": origin}
        if (joint.get("type") == "revolute" and joint.get("axis", "y") == joints[root].get("axis", "y")
                and _is_zero(origin, model.parameters)):
            joints[name]["parent"] = base
            rehung.append(name)
    bodies[base] = {"mass": "0", "com": [0, 0, 0], "inertia": 0}
    free = {PIN: {"type": "translational", "parent": "world", "child": base,
                  "origin": [0, 0, 0], "axes": ["x", "z"]}}
    joints = {**free, **{k: ({**v, "parent": base, "origin": [0, 0, 0]} if k == root else v)
                         for k, v in joints.items()}}
    args = {k: v for k, v in comp.args.items() if k not in ("bodies", "joints")}
    from porthamiltonian import Model, Multibody

    out = Model(f"{model.name}_floating")          # the model with its pin at the root released
    for name, par in model.parameters.items():
        out.parameter(name, par.value, par.unit, par.doc)
    out.add(multibody, Multibody(bodies=bodies, joints=joints, **args))
    return Floating(out, root, tuple(rehung))


class _Impact:
    """What the two impact maps share: ∂x⁺/∂x⁻ from their ``tangents``."""

    def tangents(self, t: float, x: np.ndarray, p: np.ndarray, p_after: np.ndarray,
                 dx: np.ndarray, dp: np.ndarray, dp_after: np.ndarray
                 ) -> tuple[np.ndarray, float]:
        raise NotImplementedError

    def jacobian(self, t: float, x: np.ndarray, p: np.ndarray,
                 p_after: np.ndarray) -> np.ndarray:
        """∂x⁺/∂x⁻ at fixed parameters (:meth:`tangents` by the unit states)."""
        n = len(x)
        return self.tangents(t, x, p, p_after, np.eye(n), np.zeros((len(p), n)),
                             np.zeros((len(p), n)))[0]


@dataclass(frozen=True)
class ImpactMap(_Impact):
    """Plastic impact at ``point`` of a rigid walker pinned at its root, then :class:`Relabel`.

    model : the walker's compiled model; floating : the compiled :func:`floating_model` (free at
    the point ``about``); multibody : its name; relabel : the re-pinning map. ``__call__(t, x, p, p_after)`` returns
    the state just after the heel strike (momenta from the relabelled rates with the parameters
    ``p_after``, i.e. the new stance foot's position) and the impact's record.
    """

    model: CompiledModel
    floating: CompiledModel
    multibody: str
    point: str
    about: str
    relabel: Relabel
    root: str
    rehung: tuple[str, ...]
    #: the index arrays and matrices of the floating model (set by ``__post_init__``)
    _layout: dict[str, Any] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        mb, m, f = self.multibody, self.model, self.floating
        q = [i for i, s in enumerate(m.state_names) if s.startswith(f"{mb}.q.")]
        fcoords = [s for s in f.state_names if s.startswith(f"{mb}.q.")]
        coords = [m.state_names[i][len(mb) + 3:] for i in q]
        F = np.eye(len(q))                       # floated joint coordinates = F @ pinned ones
        for j in self.rehung:
            F[coords.index(j), coords.index(self.root)] = 1.0
        layout = {"q": q, "p": [i for i, s in enumerate(m.state_names) if s.startswith(f"{mb}.p.")],
                  "F": F, "F_inv": np.linalg.inv(F),
                  "fq": [f.state_index(m.state_names[i]) for i in q],
                  "fv": [fcoords.index(m.state_names[i]) for i in q],
                  "pin": [fcoords.index(f"{mb}.q.{PIN}.{a}") for a in "xz"],
                  "pin_states": [f.state_index(f"{mb}.q.{PIN}.{a}") for a in "xz"],
                  "about": [m.output_index(f"{self.about}.{a}") for a in "xz"],
                  "params": [f.param_names.index(n) for n in m.param_names if n in f.param_names],
                  "mine": [i for i, n in enumerate(m.param_names) if n in f.param_names],
                  "switched": _switches(f, mb)}
        object.__setattr__(self, "_layout", layout)

    def floating_state(self, t: float, x: np.ndarray,
                       p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(state, joint rates, parameters) of the floating model at the walker's state ``x``:
        the same configuration and velocities, the free base at the hip moving with it."""
        mb, lay = self.multibody, self._layout
        v = np.linalg.solve(self.model.matrix(f"{mb}.M", t, x, p), x[lay["p"]])
        y = self.model.outputs(t, x, p)
        xf = np.zeros(self.floating.n_states)
        xf[lay["fq"]] = lay["F"] @ x[lay["q"]]
        xf[lay["pin_states"]] = y[lay["about"]]
        pf = self.floating.param_defaults.copy()
        pf[lay["params"]] = np.asarray(p)[lay["mine"]]
        vf = np.zeros(len(lay["fq"]) + 2)
        vf[lay["fv"]] = lay["F"] @ v
        vf[lay["pin"]] = self.model.matrix(f"{mb}.J.{self.about.split('.', 1)[1]}", t, x, p) @ v
        return xf, vf, pf

    def _rows(self, t: float, xf: np.ndarray, pf: np.ndarray) -> list[str]:
        """The impact's constraint matrices on the floating model at (xf, pf): the striking
        point's Jacobian, then those of the active constraints (:meth:`_held`)."""
        return [f"{self.multibody}.J.{self.point.split('.', 1)[1]}", *self._held(t, xf, pf)]

    def _held(self, t: float, xf: np.ndarray, pf: np.ndarray) -> list[str]:
        """The constraint matrices (``<multibody>.G.<constraint>``) of the floating model's
        constraints active at (xf, pf): a locked knee stays locked through the heel strike. The
        set is piecewise constant in the state, so it has no derivative."""
        lay = self._layout
        if not lay["switched"]:
            return []
        yf = self.floating.outputs(t, xf, pf)
        return [f"{self.multibody}.G.{c}" for c, k in lay["switched"] if yf[k] > 0.5]

    def __call__(self, t: float, x: np.ndarray, p: np.ndarray,
                 p_after: np.ndarray) -> tuple[np.ndarray, dict]:
        from porthamiltonian.simulation.impact import model_impact  # (rigid walkers only)

        mb, lay = self.multibody, self._layout
        xf, vf, pf = self.floating_state(t, x, p)
        imp = model_impact(self.floating, xf, pf, self._rows(t, xf, pf), f"{mb}.M", t=t,
                           v_minus=vf)
        pin_v = self.floating.matrix(f"{mb}.J.{PIN}_point", t, imp.x_plus, pf) @ imp.impact.v_plus
        impact = imp.impact
        y = self.model.outputs(t, x, p)
        v_new = self.relabel.rates(lay["F_inv"] @ impact.v_plus[lay["fv"]])
        x_new = self.relabel.state(x, y)
        x_new[lay["p"]] = self.model.matrix(f"{mb}.M", t, x_new, p_after) @ v_new
        info = {"impact_energy_lost": impact.energy_lost, "impulse": impact.impulse.tolist(),
                "trailing_foot_normal_velocity": float(pin_v[1]),
                "constraint_velocity": float(np.max(np.abs(impact.constraint_velocity)))}
        return x_new, info

    def tangents(self, t: float, x: np.ndarray, p: np.ndarray, p_after: np.ndarray,
                 dx: np.ndarray, dp: np.ndarray, dp_after: np.ndarray
                 ) -> tuple[np.ndarray, float]:
        """dx⁺ = ∂x⁺/∂x dx + ∂x⁺/∂p dp + ∂x⁺/∂p_after dp_after for K columns of tangents
        (dx: n x K, dp and dp_after: parameters x K; dp_after the tangents of the parameters
        after the heel strike, e.g. the new stance foot's position), and the largest error
        estimate of the differences relative to the largest value (module docstring)."""
        mb, lay, m = self.multibody, self._layout, self.model
        x, p, p_after = (np.asarray(a, dtype=float) for a in (x, p, p_after))
        n, K = len(x), dx.shape[1]
        errors: list[float] = []

        def along(fun: Any, at: np.ndarray, d: np.ndarray) -> np.ndarray:
            """fun's derivatives along the columns d; its error relative to the larger of the
            derivatives and fun's values (a derivative that is nearly 0, e.g. of a mass matrix
            that hardly depends on q, is not a scale)."""
            r = directional(fun, at, d)
            size = max(float(np.max(np.abs(r.value), initial=0.0)),
                       float(np.max(np.abs(fun(at)), initial=0.0)))
            errors.append(r.max_error / size if size > 0 else 0.0)
            return r.value

        M = m.matrix(f"{mb}.M", t, x, p)
        v = np.linalg.solve(M, x[lay["p"]])
        hip = f"{mb}.J.{self.about.split('.', 1)[1]}"
        read = sorted({*lay["about"], *(o for _, o in self.relabel.b_outputs)})   # outputs used

        def walker_in(w: np.ndarray) -> np.ndarray:
            xx, pp = w[:n], w[n:]
            return np.concatenate([m.matrix(f"{mb}.M", t, xx, pp) @ v,
                                   m.matrix(hip, t, xx, pp) @ v])

        def positions(w: np.ndarray) -> np.ndarray:
            return m.outputs(t, w[:n], w[n:])[read]

        at, d = np.concatenate([x, p]), np.vstack([dx, dp])
        d_in = along(walker_in, at, d)              # (apart: each skips what it does not read)
        nv = len(v)
        dv = np.linalg.solve(M, dx[lay["p"]] - d_in[:nv])
        dy = np.zeros((len(m.output_names), K))
        dy[read] = along(positions, at, d)
        xf, vf, pf = self.floating_state(t, x, p)
        f = self.floating
        dxf = np.zeros((f.n_states, K))
        dxf[lay["fq"]] = lay["F"] @ dx[lay["q"]]
        dxf[lay["pin_states"]] = dy[lay["about"]]
        dpf = np.zeros((len(pf), K))
        dpf[lay["params"]] = dp[lay["mine"]]
        dvf = np.zeros((len(vf), K))
        dvf[lay["fv"]] = lay["F"] @ dv
        dvf[lay["pin"]] = d_in[nv:] + m.matrix(hip, t, x, p) @ dv
        rows = self._rows(t, xf, pf)
        from porthamiltonian.simulation.impact import model_impact

        imp = model_impact(f, xf, pf, rows, f"{mb}.M", t=t, v_minus=vf).impact
        v_plus, lam = imp.v_plus, imp.impulse
        nf = len(vf)

        def floating_in(w: np.ndarray) -> np.ndarray:
            xx, pp = w[:f.n_states], w[f.n_states:]
            G = np.vstack([f.matrix(r, t, xx, pp) for r in rows])
            return np.concatenate([f.matrix(f"{mb}.M", t, xx, pp) @ (vf - v_plus) + G.T @ lam,
                                   -G @ v_plus])

        rhs = along(floating_in, np.concatenate([xf, pf]), np.vstack([dxf, dpf]))
        Mf = f.matrix(f"{mb}.M", t, xf, pf)
        G = np.vstack([f.matrix(r, t, xf, pf) for r in rows])
        rhs[:nf] += Mf @ dvf
        diag = np.diag(Mf)                  # the impact's scaling D = diag(M_f)^-1/2
        s = np.concatenate([np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)),
                                     1.0), np.ones(len(G))])
        Kf = np.block([[Mf, G.T], [G, np.zeros((len(G), len(G)))]])
        dv_plus = (s[:, None] * np.linalg.solve(s[:, None] * Kf * s[None, :],
                                                s[:, None] * rhs))[:nf]
        dv_new = self.relabel.rates(lay["F_inv"] @ dv_plus[lay["fv"]])
        y = m.outputs(t, x, p)
        x_new = self.relabel.state(x, y)
        v_new = self.relabel.rates(lay["F_inv"] @ v_plus[lay["fv"]])
        pos = list(self.relabel.positions)
        dx_new = np.array(dx, dtype=float)
        dx_new[pos] = self.relabel.A @ dx[pos]
        for k, o in self.relabel.b_outputs:
            dx_new[pos[k]] += dy[o]
        dx_new[lay["p"]] = 0.0

        def walker_out(w: np.ndarray) -> np.ndarray:
            return m.matrix(f"{mb}.M", t, w[:n], w[n:]) @ v_new

        d_out = along(walker_out, np.concatenate([x_new, p_after]), np.vstack([dx_new, dp_after]))
        dx_new[lay["p"]] = d_out + m.matrix(f"{mb}.M", t, x_new, p_after) @ dv_new
        return dx_new, max(errors, default=0.0)


def _switches(model: CompiledModel, multibody: str) -> list[tuple[str, int]]:
    """(constraint, index of its ``active`` output) of every loop and constraint of
    ``multibody`` in ``model``."""
    out: dict[str, int] = {}
    for rows in constraint_rows(model):
        if rows.name == multibody:
            for (c, _), k in zip(rows.rows, rows.active):
                out.setdefault(c, k)
    return list(out.items())


@dataclass(frozen=True)
class ConstraintImpact(_Impact):
    """The plastic impact onto ``constraint`` of the walker's multibody ``multibody`` (a knee
    strike onto the knee's lock; module docstring). ``__call__(t, x, p, p_after)`` returns the
    state just after it (the configuration unchanged, the momenta jumped; the constraint's rows
    and those active at ``p`` hold) and its record; ``p_after`` (the switch set) is not read."""

    model: CompiledModel
    multibody: str
    constraint: str
    _onto: Any = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from porthamiltonian.simulation.switching import impact_onto  # (knee strikes only)

        object.__setattr__(self, "_onto", impact_onto(self.model, self.multibody,
                                                      self.constraint))

    def __call__(self, t: float, x: np.ndarray, p: np.ndarray,
                 p_after: np.ndarray) -> tuple[np.ndarray, dict]:
        x_new, impact = self._onto(t, x, p)
        info = {"impact_energy_lost": impact.energy_lost, "impulse": impact.impulse.tolist(),
                "constraint_velocity": float(np.max(np.abs(impact.constraint_velocity)))}
        return x_new, info

    def tangents(self, t: float, x: np.ndarray, p: np.ndarray, p_after: np.ndarray,
                 dx: np.ndarray, dp: np.ndarray, dp_after: np.ndarray
                 ) -> tuple[np.ndarray, float]:
        """dx⁺ = ∂x⁺/∂x dx + ∂x⁺/∂p dp for K columns of tangents (as
        :meth:`ImpactMap.tangents`; ``p_after`` is not read, so neither is ``dp_after``), by
        fourth-order differences of the whole impact along each column, and the largest error
        estimate relative to the largest value."""
        x, p = np.asarray(x, dtype=float), np.asarray(p, dtype=float)
        n = len(x)
        at = np.concatenate([x, p])
        r = directional(lambda w: self(t, w[:n], w[n:], p_after)[0], at, np.vstack([dx, dp]))
        size = max(float(np.max(np.abs(r.value), initial=0.0)), float(np.max(np.abs(x))))
        return r.value, (r.max_error / size if size > 0 else 0.0)
