# TEMPORARY stand-in until the contact branch is merged (will be replaced by gc_ocp.contact.laws).
import casadi as ca


def unit_force_expr(p, v, k, n, c, mu, ground, belt, eps_x, eps_v):
    x = ground - p[2]
    xs = 0.5 * (x + ca.sqrt(x * x + eps_x * eps_x))
    xdot = -v[2]
    u = 1 + c * xdot
    damp = 0.5 * (u + ca.sqrt(u * u + 1e-4))
    fn = k * xs**n * damp
    vs = v[:2] - belt[:2]
    ft = -mu * fn * vs / ca.sqrt(ca.sumsqr(vs) + eps_v * eps_v)
    return ca.vertcat(ft, fn)
