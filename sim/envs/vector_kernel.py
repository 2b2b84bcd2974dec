"""Compiled per-step bookkeeping of the batched WaypointNav env (``sim.envs.vector_nav``):
the true state of N vehicles read from MjData, their altitudes over the seabed grid, the
navigation readings merged into the held measurements, and the rewards, each a loop over
the N rows with the arithmetic of the single env (``VehicleHandle.state``,
``Seabed.height``, ``UnderseaEnv._advance``, ``WaypointNavEnv._get_rew``), compiled by
numba (cache on disk): at N = 64 a numpy version of the same spends more time in ~100
small array calls than MuJoCo spends stepping the 64 vehicles.
"""

from __future__ import annotations

import math

import numba

from sim.navigation.batch_kernel import wrap


@numba.njit(cache=True)
def _height(z, x0, dx, y0, dy, px, py):
    """``Seabed.height`` of one point on grid z (ny, nx) with axes x0 + i dx, y0 + j dy."""
    ny, nx = z.shape
    fx = min(max((px - x0) / dx, 0.0), nx - 1.000001)
    fy = min(max((py - y0) / dy, 0.0), ny - 1.000001)
    ix = int(fx)
    iy = int(fy)
    tx = fx - ix
    ty = fy - iy
    z00 = z[iy, ix]
    z11 = z[iy + 1, ix + 1]
    if ty > tx:
        zo, a, b = z[iy + 1, ix], tx, ty
    else:
        zo, a, b = z[iy, ix + 1], ty, tx
    return z00 + (b - a) * (zo - z00) + a * (z11 - z00)


@numba.njit(cache=True)
def truth(qpos, qvel, qadr, vadr, z_mesh, z_grid, ax, pos, quat, vb, om, alt, rpy):
    """Positions, wxyz quaternions, body velocities, body rates (N, 3|4), altitudes (N,)
    and (roll, pitch, yaw) (N, 3) of the vehicles whose free joints start at qadr[:, 0]
    (qpos) and vadr[:, 0] (qvel). Altitude: over the mesh heights z_mesh inside the grid
    (axes ax = x0, dx, y0, dy, x_last, y_last), over the grid z_grid's nearest edge
    outside (the single env's ray and its fallback)."""
    x0, dx, y0, dy, x1, y1 = ax[0], ax[1], ax[2], ax[3], ax[4], ax[5]
    for i in range(qadr.shape[0]):
        a = qadr[i, 0]
        for j in range(3):
            pos[i, j] = qpos[a + j]
        w, x, y, zq = qpos[a + 3], qpos[a + 4], qpos[a + 5], qpos[a + 6]
        quat[i, 0], quat[i, 1], quat[i, 2], quat[i, 3] = w, x, y, zq
        b = vadr[i, 0]
        v0, v1, v2 = qvel[b], qvel[b + 1], qvel[b + 2]
        # columns of the body->world rotation (mju_quat2Mat); v_body = Rᵀ v_world
        r00, r10, r20 = 1 - 2 * (y * y + zq * zq), 2 * (x * y + w * zq), 2 * (x * zq - w * y)
        r01, r11, r21 = 2 * (x * y - w * zq), 1 - 2 * (x * x + zq * zq), 2 * (y * zq + w * x)
        r02, r12, r22 = 2 * (x * zq + w * y), 2 * (y * zq - w * x), 1 - 2 * (x * x + y * y)
        vb[i, 0] = r00 * v0 + r10 * v1 + r20 * v2
        vb[i, 1] = r01 * v0 + r11 * v1 + r21 * v2
        vb[i, 2] = r02 * v0 + r12 * v1 + r22 * v2
        for j in range(3):
            om[i, j] = qvel[b + 3 + j]
        px, py = pos[i, 0], pos[i, 1]
        inside = x0 <= px <= x1 and y0 <= py <= y1
        zs = _height(z_mesh if inside else z_grid, x0, dx, y0, dy, px, py)
        alt[i] = pos[i, 2] - zs
        rpy[i, 0] = math.atan2(2 * (w * x + y * zq), 1 - 2 * (x * x + y * y))
        rpy[i, 1] = math.asin(min(max(2 * (w * y - zq * x), -1.0), 1.0))
        rpy[i, 2] = math.atan2(2 * (w * zq + x * y), 1 - 2 * (y * y + zq * zq))


@numba.njit(cache=True)
def merge_nav(active, out, rep, delta, meas, nav_pose):
    """``UnderseaEnv._advance`` with a NavBatch, for the active rows: the readings
    reported this tick (out, rep of ``NavBatch``) replace the held measurements meas
    (N, 8: DVL velocity 0:3, gyro z 3, depth 4, DVL altitude 5, roll 6, pitch 7) and the
    nav pose (N, 3) moves by the increment delta (``slam.pipeline.lagged.apply_increment``)."""
    for i in range(active.shape[0]):
        if not active[i]:
            continue
        if rep[i, 1]:
            if rep[i, 2]:
                meas[i, 0], meas[i, 1], meas[i, 2] = out[i, 3], out[i, 4], out[i, 5]
            meas[i, 5] = out[i, 6]
        if rep[i, 0]:
            meas[i, 3] = out[i, 2]
        if rep[i, 3]:
            meas[i, 4] = out[i, 7]
        if rep[i, 4]:
            meas[i, 6], meas[i, 7] = out[i, 8], out[i, 9]
        x, y, phi = nav_pose[i, 0], nav_pose[i, 1], nav_pose[i, 2]
        c, s = math.cos(phi), math.sin(phi)
        d0, d1 = delta[i, 0], delta[i, 1]
        nav_pose[i, 0] = x + c * d0 - s * d1
        nav_pose[i, 1] = y + s * d0 + c * d1
        nav_pose[i, 2] = wrap(phi + delta[i, 2])


@numba.njit(cache=True)
def ideal_nav(pos, vb, om, alt, rpy, meas, nav_pose):
    """Ideal navigation (``nav_sensors=False``): the true state as the measurements."""
    for i in range(pos.shape[0]):
        for j in range(3):
            meas[i, j] = vb[i, j]
        meas[i, 3] = om[i, 2]
        meas[i, 4] = -pos[i, 2]
        meas[i, 5] = alt[i]
        meas[i, 6], meas[i, 7] = rpy[i, 0], rpy[i, 1]
        nav_pose[i, 0], nav_pose[i, 1], nav_pose[i, 2] = pos[i, 0], pos[i, 1], rpy[i, 2]


@numba.njit(cache=True)
def rewards(pos, alt, u, wps, k, prev_dist, radius, terms, reward, collided):
    """``WaypointNavEnv._get_rew`` of every row: terms (N, 5) progress, waypoint, effort,
    low altitude, collision; their sum reward (N,); collided (N,); advances the waypoint
    index k and prev_dist as the single env does."""
    n_wp = wps.shape[1]
    for i in range(pos.shape[0]):
        kk = min(k[i], n_wp - 1)
        e0, e1, e2 = wps[i, kk, 0] - pos[i, 0], wps[i, kk, 1] - pos[i, 1], wps[i, kk, 2] - pos[i, 2]
        dist = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        reached = dist < radius
        col = alt[i] < 0.3 or pos[i, 2] > -0.2
        collided[i] = col
        eff = 0.0
        for j in range(u.shape[1]):
            eff += u[i, j] * u[i, j]
        terms[i, 0] = prev_dist[i] - dist
        terms[i, 1] = 10.0 if reached else 0.0
        terms[i, 2] = -(0.01 * eff)
        terms[i, 3] = -1.0 if alt[i] < 2.0 else -0.0
        terms[i, 4] = -50.0 if col else 0.0
        reward[i] = (((terms[i, 0] + terms[i, 1]) + terms[i, 2]) + terms[i, 3]) + terms[i, 4]
        if reached:
            k[i] += 1
            if k[i] < n_wp:
                e0 = wps[i, k[i], 0] - pos[i, 0]
                e1 = wps[i, k[i], 1] - pos[i, 1]
                e2 = wps[i, k[i], 2] - pos[i, 2]
                dist = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        prev_dist[i] = dist


@numba.njit(cache=True)
def actions(a, done, u, clipped):
    """``UnderseaEnv._check_action`` of N rows: False when an entry of a (N, n_act) is not
    finite (nothing written then); else u = a clipped to [-1, 1] (rows of the done envs
    zeroed: their action is ignored) and clipped[i] = row i needed clipping and is not done."""
    n, m = a.shape
    for i in range(n):
        for j in range(m):
            if not math.isfinite(a[i, j]):
                return False
    for i in range(n):
        c = False
        for j in range(m):
            x = float(a[i, j])
            y = min(max(x, -1.0), 1.0)
            c = c or y != x
            u[i, j] = 0.0 if done[i] else y
        clipped[i] = c and not done[i]
    return True


@numba.njit(cache=True)
def ends(collided, k, n_wp, elapsed, max_steps, pos, nav_pose, terminated, truncated, nav_err):
    """Episode ends of every row (terminated: collision or every waypoint reached;
    truncated: ``elapsed >= max_steps``, never when max_steps < 0) and the nav position
    error (N,) m, |nav xy - true xy|."""
    for i in range(collided.shape[0]):
        terminated[i] = collided[i] or k[i] >= n_wp
        truncated[i] = max_steps >= 0 and elapsed[i] >= max_steps
        nav_err[i] = math.hypot(nav_pose[i, 0] - pos[i, 0], nav_pose[i, 1] - pos[i, 1])


@numba.njit(cache=True)
def observe(nav_pose, wps, k, meas, obs):
    """Observations obs (N, 17) float32 (the table of ``WaypointNavEnv``) from the nav
    poses (N, 3) [x, y, yaw], the waypoints (N, n_wp, 3) and indices k (N,) and the held
    measurements meas (N, 8): DVL velocity 0:3, yaw rate 3, depth 4, altitude 5
    (non-finite -> 0), roll 6, pitch 7. Float32 where ``WaypointNavEnv._get_obs`` is.
    Columns 4, 5 (sin, cos of the waypoint's bearing atan2(obs[:, 1], obs[:, 0]) in
    float32) are left to the caller: numpy's float32 loops, which numba's atan2f, sinf
    and cosf differ from in the last bit."""
    n_wp = wps.shape[1]
    for i in range(nav_pose.shape[0]):
        kk = min(k[i], n_wp - 1)
        x, y, yaw = nav_pose[i, 0], nav_pose[i, 1], nav_pose[i, 2]
        dx, dy = wps[i, kk, 0] - x, wps[i, kk, 1] - y
        c, s = math.cos(yaw), math.sin(yaw)
        obs[i, 0] = c * dx + s * dy
        obs[i, 1] = -s * dx + c * dy
        obs[i, 2] = wps[i, kk, 2] - (-meas[i, 4])
        obs[i, 3] = math.hypot(dx, dy)
        for j in range(3):
            obs[i, 6 + j] = meas[i, j]
        obs[i, 9] = meas[i, 3]
        obs[i, 10] = meas[i, 4]
        obs[i, 11] = meas[i, 5] if math.isfinite(meas[i, 5]) else 0.0
        obs[i, 12], obs[i, 13] = meas[i, 6], meas[i, 7]
        obs[i, 14], obs[i, 15] = s, c
        obs[i, 16] = n_wp - k[i]
