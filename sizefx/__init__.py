"""sizefx: the accelerometer size effect in strapdown inertial navigation.

Conventions (stated once here; ``tests/test_conventions.py`` checks each rule)
-------------------------------------------------------------------------------
Units
    SI and radians inside the package: m, s, m/s, m/s^2, rad, rad/s. Degrees,
    g (9.80665 m/s^2), deg/s, arcsec, ppm and ug appear only at the file and
    command-line boundary, and every such variable carries its unit in its name
    (``lat_deg``, ``tilt_arcsec``, ``bias_ug``).
Body frame ``b``
    x forward, y right, z down. Accelerometer channel i (i = x, y, z) is the
    accelerometer whose sensitive axis is body axis i (up to misalignment);
    gyro channel i likewise.
Navigation frame ``n``
    Local-level North-East-Down (NED) at the position of the reference point.
Earth
    WGS-84 ellipsoid, Earth rate 7.292115e-5 rad/s, normal gravity by the
    Somigliana formula with height terms (:mod:`sizefx.earth`).
Attitude
    Quaternions are scalar-first ``[q0, q1, q2, q3]``, Hamilton product, and
    rotate body vectors into NED: ``v_n = q * v_b * conj(q)``. Direction cosine
    matrices are named by the frames they connect so that adjacent letters
    cancel: ``mat_nb @ v_b = v_n``. Roll, pitch, heading are the z-y-x Euler
    angles of ``mat_nb = Rz(heading) @ Ry(pitch) @ Rx(roll)``.
Rates
    ``omega_ib_b`` is the angular rate of the body with respect to inertial
    space, resolved in the body frame: what ideal gyros read.
    ``f_b`` is specific force (non-gravitational acceleration) in the body
    frame: what ideal, co-located accelerometers read.
Size effect
    ``r_i`` (``r_x_b``, ``r_y_b``, ``r_z_b``) is the vector from the reference
    point of the motion (the rotation centre of a table, or the navigation
    point of a vehicle) to the sensitive mass of accelerometer i, in body axes,
    metres. ``r_i = r + d_i``: ``r`` the offset to the triad point, ``d_i`` the
    arm of accelerometer i from the triad point (Morozov & Bogdanov 2024,
    DOI 10.18522/2311-3103-2024-1-234-246). Accelerometer i reads
    ``u_i . (f_b + omegadot_ib_b x r_i + omega_ib_b x (omega_ib_b x r_i))``.
Time
    Seconds on the IMU clock. Increments (``dtheta``, ``dvel``) stamped
    ``time[k]`` cover the interval ``(time[k-1], time[k]]``.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
