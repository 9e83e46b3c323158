"""The MuJoCo two-axis rate table (``rate_table.xml`` beside this file) and its truth.

The table is driven open-loop by servo commands built from a motion program (``sim.motion``) and
rolled out with ``mujoco.rollout`` in C. The true rate at the FOG is what a FOG integrates: the
integral over the sample interval of the site's body rate, divided by the interval. It is built
from the physics steps consistently with the poses (``_HingeChain``): MuJoCo's semi-implicit
Euler moves each hinge across a step by the velocity after the step, so the body rate that carries
the pose across a step is the one of the joint angles moving linearly between the step's two
states, and its integral over the step is closed form. Summed over a sample's steps it keeps the
coning term of a tilt while the turntable turns (it is not the rotation vector between the
sample's bounding poses), and a strapdown integration of it reproduces the poses to the
integration algorithm's own order (``tests/sim/test_truth_closure.py``; issue 42: the former
truth, the mean of MuJoCo's ``gyro`` before each step, missed a 193 s program's final pose by
294 arcsec). The specific force comes from the site's velocity differenced over each physics step
(``_Roller._specific_force``: MuJoCo's ``accelerometer`` reads the explicit joint acceleration,
wrong under ``implicitfast`` while the turntable accelerates), averaged over the FOG sample
interval. The Earth's rate is added analytically (``sim.earth``), averaged over the sample in the
same way: the world-fixed Earth rate is projected on the sensor axes through the mean over the
sample of the rotation matrix (linear in the products of the quaternion's components; over each
step the trapezoid of its two poses), so a sensor axis that turns 60 deg within one sample gets
the mean, not the sample-start value. (``gravity``, the reference projection of 'up', stays the
sample-start value, of norm exactly g / G0; the specific force is averaged.)

Static holds longer than ``settle_time`` are simulated until the table has settled and then
continued at the settled state: a table at rest under a constant command stays at rest, and a
14-hour thermal run would otherwise cost 50 million physics steps. The fast path checks that the
table has really settled (joint rates below 1e-9 rad/s) and simulates in full when it has not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout

from fogcomp.units import G0

from . import earth
from .motion import Hold, segment_commands

__all__ = ["TableConfig", "Truth", "load_model", "simulate_truth", "MODEL_PATH"]

MODEL_PATH = Path(__file__).with_name("rate_table.xml")

# sensor layout (name -> slice in sensordata), fixed by rate_table.xml; checked at load
_SENSORS = {
    "fog_gyro": 3, "fog_linvel": 3, "fog_quat": 4, "fog_pos": 3, "tilt_angle": 1,
    "tilt_rate": 1, "turn_angle": 1, "turn_rate": 1, "tilt_quat": 4, "turntable_quat": 4,
}
SETTLE_RATE_TOL = 1e-9  # rad/s


@dataclass(frozen=True)
class TableConfig:
    """Rate-table and site parameters (SI).

    radius : FOG mounting offset from the turntable axis, m (along the turntable's x).
    height : FOG height above the turntable top, m.
    latitude : lab latitude, rad.  heading : azimuth of the table's x (tilt) axis from north, rad.
    gravity : local gravity magnitude, m/s^2.  physics_dt : maximum physics step, s.
    tilt_slew : peak tilt rate of a tilt move, rad/s.  settle_time : see module doc, s.
    turn_accel : turntable acceleration limit of rate changes, rad/s^2.
    earth_rate : include the Earth's rotation in the truth.
    turn_axis_error : the turntable's axis tilted from the platform normal toward the platform's
    x, rad (an orthogonality error: the FOG cones by up to twice it as the turntable turns).
    level_error : the base tilted about world x and y, rad (a table not levelled).
    rate_error : the turntable's rate error beyond its servo's, dimensionless: the table is
    driven at (1 + rate_error) times the rate (and angle) it is commanded, a timebase or encoder
    scale error of the rate loop; ``Truth.turn_rate_cmd`` stays the commanded (set) rate.
    A lab (sim/lab.py) believes all three are zero.
    """

    radius: float = 0.0
    height: float = 0.06
    latitude: float = math.radians(45.0)
    heading: float = 0.0
    gravity: float = G0
    physics_dt: float = 1e-3
    tilt_slew: float = math.radians(20.0)
    settle_time: float = 5.0
    turn_accel: float = math.radians(200.0)
    earth_rate: bool = True
    turn_axis_error: float = 0.0
    level_error: tuple[float, float] = (0.0, 0.0)
    rate_error: float = 0.0


@dataclass(frozen=True)
class Truth:
    """Ground truth at the FOG sample rate; arrays of n samples.

    t : sample start times, s.  rate : angular rate of the sensor frame w.r.t. inertial space,
    in sensor axes, averaged over each sample (its integral over the sample, the FOG's angle
    increment, times fs), rad/s, shape (n, 3).  table_rate : the same without the Earth's rate
    (the table's own motion), rad/s.  specific_force : accelerometer reading
    averaged over each sample, in g (9.80665 m/s^2), shape (n, 3).  gravity : gravity projection on
    the sensor axes (no motion), in g, shape (n, 3).  tilt, turn : joint angles at each
    sample's start, rad.  tilt_rate, turn_rate : joint rates averaged over each sample (the
    angle's change over it times fs), rad/s.  tilt_cmd, turn_rate_cmd : commands, rad and rad/s
    (the tilt at each sample's start, the turntable rate averaged over it; turn_rate_cmd_first:
    the turntable rate command at each sample's start).
    fog_quat, tilt_quat, turntable_quat : body/site orientations (w, x, y, z) in the world frame.
    fog_pos : FOG site position, m, shape (n, 3).
    """

    t: np.ndarray
    fs: float
    rate: np.ndarray
    table_rate: np.ndarray
    specific_force: np.ndarray
    gravity: np.ndarray
    tilt: np.ndarray
    turn: np.ndarray
    tilt_rate: np.ndarray
    turn_rate: np.ndarray
    tilt_cmd: np.ndarray
    turn_rate_cmd: np.ndarray
    fog_quat: np.ndarray
    tilt_quat: np.ndarray
    turntable_quat: np.ndarray
    fog_pos: np.ndarray
    physics_steps: int = 0
    settled_fast_path_s: float = 0.0
    turn_rate_cmd_first: np.ndarray | None = None   # the rate command at each sample's start

    def as_arrays(self) -> dict[str, np.ndarray]:
        return {k: v for k, v in self.__dict__.items() if isinstance(v, np.ndarray)}


def load_model(cfg: TableConfig = TableConfig(), dt: float | None = None) -> mujoco.MjModel:
    """Compile the rate table with the FOG at ``cfg.radius`` and the given physics step."""
    spec = mujoco.MjSpec.from_file(str(MODEL_PATH))
    spec.body("fog").pos = [cfg.radius, 0.0, cfg.height]
    spec.option.gravity = [0.0, 0.0, -cfg.gravity]
    spec.option.timestep = cfg.physics_dt if dt is None else dt
    if cfg.turn_axis_error:
        a = cfg.turn_axis_error
        spec.joint("turn").axis = [math.sin(a), 0.0, math.cos(a)]
    lx, ly = cfg.level_error
    if lx or ly:
        # the base rotated by the small-angle vector (lx, ly, 0): axis-angle as a quaternion
        ang = math.hypot(lx, ly)
        spec.body("base").quat = [math.cos(ang / 2), math.sin(ang / 2) * lx / ang,
                                  math.sin(ang / 2) * ly / ang, 0.0]
    model = spec.compile()
    for name, dim in _SENSORS.items():
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
        if sid < 0 or model.sensor_dim[sid] != dim:
            raise RuntimeError(f"{MODEL_PATH}: sensor {name!r} missing or not of dimension {dim}")
    return model


def _sensor_slices(model) -> dict[str, slice]:
    out = {}
    for name in _SENSORS:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
        a = int(model.sensor_adr[sid])
        out[name] = slice(a, a + int(model.sensor_dim[sid]))
    return out


def substeps_for(fs: float, max_dt: float) -> tuple[int, float]:
    """Physics steps per FOG sample and the physics step: the largest dt <= max_dt dividing 1/fs."""
    k = max(1, math.ceil((1.0 / fs) / max_dt - 1e-9))
    return k, 1.0 / (fs * k)


def _quat_rotate_inv(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Express world vectors v (n, 3) in the frame of orientation q (n, 4), (w, x, y, z).

    R (frame -> world) is the usual rotation matrix of q; the result is R^T v.
    """
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    R = np.empty(q.shape[:1] + (3, 3))
    R[:, 0, 0] = 1 - 2 * (y * y + z * z)
    R[:, 0, 1] = 2 * (x * y - w * z)
    R[:, 0, 2] = 2 * (x * z + w * y)
    R[:, 1, 0] = 2 * (x * y + w * z)
    R[:, 1, 1] = 1 - 2 * (x * x + z * z)
    R[:, 1, 2] = 2 * (y * z - w * x)
    R[:, 2, 0] = 2 * (x * z - w * y)
    R[:, 2, 1] = 2 * (y * z + w * x)
    R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return np.einsum("nji,nj->ni", R, v)


def _quat_mat(q) -> np.ndarray:
    m = np.empty(9)
    mujoco.mju_quat2Mat(m, np.asarray(q, dtype=float))
    return m.reshape(3, 3)


class _HingeChain:
    """The sensor site's angle increment over each physics step, from its two hinge joints.

    The site hangs from an outer hinge (the tilt) carrying an inner hinge (the turntable), with
    fixed bodies between. MuJoCo's semi-implicit Euler moves a hinge's angle across a step by
    ``qvel[j+1] dt`` (the velocity after the step), linearly, so over the step the inner angle is
    phi(s) = phi0 + s dphi and the outer theta(s) = theta0 + s dtheta, s in [0, 1]. The body rate
    of the inner body along that path, in its own axes, is

        omega = dphi/dt a + dtheta/dt R_a(phi(s))^T P^T e

    (a: inner axis in the inner body; e: outer axis in the outer body; P: the inner body's frame
    at phi = 0 in the outer body's). Its integral over the step is closed form, with
    phi_m = phi0 + dphi / 2 and S = sin(dphi / 2) / (dphi / 2):

        dphi a + dtheta [v cos(phi_m) S - (a x v) sin(phi_m) S + a (a.v) (1 - cos(phi_m) S)],
        v = P^T e,

    rotated into the site's axes (C^T, C: the site's frame in the inner body's). Summed over a
    sample's steps this is what a FOG integrates: it carries the poses exactly (not the rotation
    vector between them: the coning term of a tilt while turning stays in).
    """

    def __init__(self, model, site: str = "fog_site"):
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site)
        C = _quat_mat(model.site_quat[sid])
        body = int(model.site_bodyid[sid])
        joints = []   # (joint id, rotation from the joint's body to the body below the chain)
        R = C
        while body != 0:
            n = int(model.body_jntnum[body])
            if n > 1 or (n == 1 and model.jnt_type[model.body_jntadr[body]]
                         != mujoco.mjtJoint.mjJNT_HINGE):
                raise RuntimeError(f"{MODEL_PATH}: body {body} of the sensor's chain must have "
                                   f"at most one hinge joint")
            if n == 1:
                joints.append((int(model.body_jntadr[body]), R))
                R = np.eye(3)
            R = _quat_mat(model.body_quat[body]) @ R
            body = int(model.body_parentid[body])
        if len(joints) != 2:
            raise RuntimeError(f"{MODEL_PATH}: the sensor must hang from two hinges, found "
                               f"{len(joints)}")
        (inner, C_inner), (outer, _) = joints
        # P: the inner body's frame (phi = 0) in the outer body's: body_quat of the inner body
        # and of the fixed bodies between the two joints
        P = np.eye(3)
        b = int(model.jnt_bodyid[inner])
        chain = []
        while b != int(model.jnt_bodyid[outer]):
            chain.append(_quat_mat(model.body_quat[b]))
            b = int(model.body_parentid[b])
        for M in reversed(chain):
            P = P @ M
        self.C_T = C_inner.T
        self.a = model.jnt_axis[inner] / np.linalg.norm(model.jnt_axis[inner])
        e = model.jnt_axis[outer] / np.linalg.norm(model.jnt_axis[outer])
        self.v = P.T @ e
        self.inner_q, self.outer_q = int(model.jnt_qposadr[inner]), int(model.jnt_qposadr[outer])

    def increments(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        """Angle increment of the site across each step, site axes, rad, shape (m, 3), from the
        joint positions before (q0) and after (q1) each step, shape (m, nq)."""
        phi0 = q0[:, self.inner_q]
        dphi = q1[:, self.inner_q] - phi0
        dth = q1[:, self.outer_q] - q0[:, self.outer_q]
        phim = phi0 + 0.5 * dphi
        S = np.sinc(dphi / (2 * np.pi))          # numpy's sinc(x) = sin(pi x) / (pi x)
        cS, sS = np.cos(phim) * S, np.sin(phim) * S
        a, v = self.a, self.v
        axv = np.cross(a, v)
        mean_v = (np.outer(cS, v) - np.outer(sS, axv) + np.outer(1.0 - cS, a * (a @ v)))
        inc = np.outer(dphi, a) + dth[:, None] * mean_v
        return inc @ self.C_T.T


class _Roller:
    """Rolls the model out chunk by chunk, carrying the state, reducing to FOG samples at once.

    Per FOG sample of ``k`` physics steps it keeps the mean of every sensor over the sample and
    the sensor values at the sample's first step (``mujoco.rollout`` reports the sensors of the
    state before each step, so step j describes time j*dt).
    """

    CHUNK_SAMPLES = 20_000

    def __init__(self, model, k: int, quat: slice, linvel: slice):
        self.model, self.k, self.quat, self.linvel = model, k, quat, linvel
        self.chain = _HingeChain(model)
        self.incs: list[np.ndarray] = []   # per sample: site angle increment, rad, (3,)
        self.dq: list[np.ndarray] = []     # per sample: joint position change, rad, (nq,)
        self.fmeans: list[np.ndarray] = []  # per sample: mean specific force, sensor axes, m/s^2
        self.scratch = mujoco.MjData(model)
        self.qq: list[np.ndarray] = []  # per sample: mean over its steps of q_i q_j, (4, 4)
        self.data = mujoco.MjData(model)
        self.nstate = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self.state = np.zeros(self.nstate)
        self.turn_cmd = 0.0  # integral of the turntable rate command, rad
        self.steps = 0
        self.means: list[np.ndarray] = []
        self.firsts: list[np.ndarray] = []
        self.ctrl_means: list[np.ndarray] = []
        self.ctrl_firsts: list[np.ndarray] = []

    def set_tilt(self, tilt: float):
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[0] = tilt
        self.data.ctrl[0] = tilt
        mujoco.mj_getState(self.model, self.data, self.state, mujoco.mjtState.mjSTATE_FULLPHYSICS)

    def run(self, tilt_cmd: np.ndarray, rate_cmd: np.ndarray) -> float:
        """Roll out servo commands (n,), n a multiple of k; returns max |qvel| of the last sample.

        The turntable's angle command is the running integral of its rate command.
        """
        dt = self.model.opt.timestep
        angle = self.turn_cmd + dt * (np.cumsum(rate_cmd) - rate_cmd)
        self.turn_cmd = float(angle[-1] + dt * rate_cmd[-1])
        ctrl = np.stack([tilt_cmd, angle, rate_cmd], axis=1)
        k, n = self.k, ctrl.shape[0]
        step = self.CHUNK_SAMPLES * k
        vmax = 0.0
        for a in range(0, n, step):
            c = ctrl[a:a + step]
            st, sd = rollout.rollout(self.model, self.data, self.state[None], c[None])
            ns = len(c) // k
            nq, nv = self.model.nq, self.model.nv
            end = self._sensors_of(st[0, -1])
            # the steps' joint positions before and after (rollout's state j is after step j)
            qa = st[0, :, 1:1 + nq]
            qb = np.vstack([self.state[None, 1:1 + nq], qa[:-1]])
            self.incs.append(self.chain.increments(qb, qa).reshape(ns, k, 3).sum(axis=1))
            self.dq.append(qa[k - 1::k] - qb[::k])
            flat = sd[0]
            sd = flat.reshape(ns, k, -1)
            self.means.append(sd.mean(axis=1))
            self.firsts.append(sd[:, 0].copy())
            # mean of R over each step by the trapezoid of its two poses (for the Earth's rate)
            q = sd[:, :, self.quat]
            q_after = np.vstack([flat[1:, self.quat], end[None, self.quat]]).reshape(ns, k, 4)
            self.qq.append((np.einsum("nki,nkj->nij", q, q)
                            + np.einsum("nki,nkj->nij", q_after, q_after)) / (2 * k))
            self.fmeans.append(self._specific_force(flat, end))
            cc = c[:, [0, 2]].reshape(ns, k, -1)
            self.ctrl_means.append(cc.mean(axis=1))
            self.ctrl_firsts.append(cc[:, 0].copy())
            vmax = float(np.max(np.abs(st[0, -k:, 1 + nq:1 + nq + nv])))
            self.state = st[0, -1].copy()
        self.steps += n
        return vmax

    def _sensors_of(self, state: np.ndarray) -> np.ndarray:
        """The sensors of a state (e.g. the chunk's final one, which no step reports)."""
        mujoco.mj_setState(self.model, self.scratch, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        mujoco.mj_forward(self.model, self.scratch)
        return self.scratch.sensordata.copy()

    def _specific_force(self, sd: np.ndarray, end: np.ndarray) -> np.ndarray:
        """Mean specific force over each sample of the chunk's steps, in sensor axes, m/s^2.

        The site's world velocity differenced over each physics step, (v[j+1] - v[j]) / dt, is
        the acceleration the integrator gave it (the step after the chunk's last comes from its
        final state); minus gravity, rotated into the sensor axes at the step's midpoint
        orientation (the normalised mean of the two quaternions), then averaged over each
        sample. MuJoCo's own accelerometer is not used: it reads the explicit joint
        acceleration, which under ``implicitfast`` and the stiff rate servo is not the one the
        table has (0.50 g tangential where alpha r is 0.036 g at 200 deg/s^2 and 0.1 m).
        """
        v = np.vstack([sd[:, self.linvel], end[self.linvel][None]])
        q = np.vstack([sd[:, self.quat], end[self.quat][None]])
        q1 = q[1:] * np.where(np.sum(q[1:] * q[:-1], axis=1) < 0, -1.0, 1.0)[:, None]
        qm = q[:-1] + q1
        qm /= np.linalg.norm(qm, axis=1)[:, None]
        f_world = np.diff(v, axis=0) / self.model.opt.timestep - self.model.opt.gravity
        f = _quat_rotate_inv(qm, f_world)
        return f.reshape(-1, self.k, 3).mean(axis=1)

    def repeat_last(self, ns: int, dt_total: float):
        """Continue the settled state for ``ns`` more samples (time advances, nothing moves)."""
        for lst in (self.means, self.firsts, self.ctrl_means, self.ctrl_firsts, self.qq,
                    self.fmeans, self.incs, self.dq):
            lst.append(np.repeat(lst[-1][-1:], ns, axis=0))
        self.state[0] += dt_total

    def collect(self):
        return (np.concatenate(self.means), np.concatenate(self.firsts),
                np.concatenate(self.ctrl_means), np.concatenate(self.ctrl_firsts),
                np.concatenate(self.qq), np.concatenate(self.fmeans),
                np.concatenate(self.incs), np.concatenate(self.dq))


def _mean_rotation(qq: np.ndarray) -> np.ndarray:
    """Mean over a sample of the rotation matrix (frame -> world) of unit quaternions (w, x, y,
    z), from the means of the products q_i q_j, shape (n, 4, 4) -> (n, 3, 3)."""
    w, x, y, z = 0, 1, 2, 3
    P = lambda i, j: qq[:, i, j]  # noqa: E731
    R = np.empty(qq.shape[:1] + (3, 3))
    R[:, 0, 0] = P(w, w) + P(x, x) - P(y, y) - P(z, z)
    R[:, 0, 1] = 2 * (P(x, y) - P(w, z))
    R[:, 0, 2] = 2 * (P(x, z) + P(w, y))
    R[:, 1, 0] = 2 * (P(x, y) + P(w, z))
    R[:, 1, 1] = P(w, w) - P(x, x) + P(y, y) - P(z, z)
    R[:, 1, 2] = 2 * (P(y, z) - P(w, x))
    R[:, 2, 0] = 2 * (P(x, z) - P(w, y))
    R[:, 2, 1] = 2 * (P(y, z) + P(w, x))
    R[:, 2, 2] = P(w, w) - P(x, x) - P(y, y) + P(z, z)
    return R


def simulate_truth(segments, fs: float, cfg: TableConfig = TableConfig(), tilt0: float = 0.0,
                   progress=None) -> Truth:
    """Run a motion program on the table and return the truth at sample rate ``fs`` (Hz).

    Every segment's duration must be a whole number of samples (the scenario loader checks).
    ``progress``, if given, is called with the fraction done after each segment.
    """
    k, dt = substeps_for(fs, cfg.physics_dt)
    model = load_model(cfg, dt)
    sl = _sensor_slices(model)
    roller = _Roller(model, k, sl["fog_quat"], sl["fog_linvel"])
    roller.set_tilt(tilt0)
    settle_samples = max(1, int(round(cfg.settle_time * fs)))
    total = sum(seg.duration for seg in segments)
    fast_s, done, tilt, last_rate = 0.0, 0.0, tilt0, 0.0
    drive = 1.0 + cfg.rate_error   # the turntable runs at drive x its command (1.0: exactly)
    for seg in segments:
        ns = int(round(seg.duration * fs))
        if abs(ns - seg.duration * fs) > 1e-6 * max(1.0, ns):
            raise ValueError(f"segment {seg.kind} lasts {seg.duration} s, not a whole number of "
                             f"samples at {fs} Hz")

        def commands(n=None, tilt_before=tilt, rate_before=last_rate):
            return segment_commands(seg, dt, tilt_before, cfg.tilt_slew, n=n,
                                    rate_before=rate_before, turn_accel=cfg.turn_accel)

        if isinstance(seg, Hold) and ns > settle_samples + 1:
            tc, rc, tilt_after = commands(n=settle_samples * k)
            vmax = roller.run(tc, rc * drive)
            rest = ns - settle_samples
            if vmax < SETTLE_RATE_TOL and rc[-1] == 0.0:
                roller.repeat_last(rest, rest / fs)
                fast_s += rest / fs
            else:
                tc, rc, _ = commands()
                roller.run(tc[settle_samples * k:], rc[settle_samples * k:] * drive)
        else:
            tc, rc, tilt_after = commands()
            roller.run(tc, rc * drive)
        tilt, last_rate = tilt_after, float(rc[-1])
        done += seg.duration
        if progress is not None:
            progress(done / total)

    means, firsts, cmean, cfirst, qq, fmean, incs, dq = roller.collect()
    ns = means.shape[0]
    table_rate = incs * fs   # the site's angle increment over each sample, as a rate
    fog_quat = firsts[:, sl["fog_quat"]]
    R_mean = _mean_rotation(qq)   # mean over each sample of R (sensor -> world)
    world_up = np.broadcast_to([0.0, 0.0, cfg.gravity / G0], (ns, 3))
    gravity = _quat_rotate_inv(fog_quat, world_up)   # at the sample's start, of norm g / G0
    rate = table_rate.copy()
    if cfg.earth_rate:
        w_world = earth.earth_rate_world(cfg.latitude, cfg.heading)
        rate += np.einsum("nji,j->ni", R_mean, w_world)
    return Truth(
        t=np.arange(ns) / fs, fs=fs, rate=rate, table_rate=table_rate,
        specific_force=fmean / G0, gravity=gravity,
        tilt=firsts[:, sl["tilt_angle"]][:, 0], turn=firsts[:, sl["turn_angle"]][:, 0],
        tilt_rate=dq[:, roller.chain.outer_q] * fs, turn_rate=dq[:, roller.chain.inner_q] * fs,
        tilt_cmd=cfirst[:, 0], turn_rate_cmd=cmean[:, 1] / drive,
        fog_quat=fog_quat, tilt_quat=firsts[:, sl["tilt_quat"]],
        turntable_quat=firsts[:, sl["turntable_quat"]], fog_pos=firsts[:, sl["fog_pos"]],
        physics_steps=roller.steps, settled_fast_path_s=fast_s,
        turn_rate_cmd_first=cfirst[:, 1] / drive,
    )
