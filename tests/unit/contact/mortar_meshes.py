"""Test meshes and independent reference computations for the mortar geometry tests."""

from __future__ import annotations

import itertools

import numpy as np

from bonecontact.common.geometry import cross2
from bonecontact.contact.clipping import clip_polygons_by_triangles, fan_quadrature
from bonecontact.contact.dual_basis import DUAL_COEFFS_TRIANGLE, shape_triangle
from bonecontact.contact.geometry import normalise
from bonecontact.contact.mortar_assembly import MortarContributions


def square_grid(
    n: int,
    lo: float,
    hi: float,
    rng: np.random.Generator,
    perturb: float = 0.25,
    flip: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Triangulated square [lo, hi]^2 with randomly perturbed interior nodes."""
    t = np.linspace(lo, hi, n + 1)
    X, Y = np.meshgrid(t, t, indexing="ij")
    pts = np.stack([X.ravel(), Y.ravel()], axis=1)
    h = (hi - lo) / n
    inner = np.all((pts > lo + 1e-12) & (pts < hi - 1e-12), axis=1)
    pts[inner] += rng.uniform(-perturb * h, perturb * h, (int(inner.sum()), 2))
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    if flip:
        tris = np.concatenate([np.stack([a, b, d], 1), np.stack([b, c, d], 1)])
    else:
        tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return pts, tris


def flat_surface(n, lo, hi, z, rng, **kw):
    pts, tris = square_grid(n, lo, hi, rng, **kw)
    return np.column_stack([pts, np.full(len(pts), z)]), tris


def sphere_cap(n, half_width, radius, rng, **kw):
    """Cap of the sphere |x| = radius over the square [-hw, hw]^2 (central projection)."""
    pts, tris = square_grid(n, -half_width, half_width, rng, **kw)
    p = np.column_stack([pts, np.ones(len(pts))])
    return radius * p / np.linalg.norm(p, axis=1, keepdims=True), tris


def arc(n_seg, radius, theta0, theta1):
    th = np.linspace(theta0, theta1, n_seg + 1)
    pts = radius * np.stack([np.cos(th), np.sin(th)], axis=1)
    segs = np.stack([np.arange(n_seg), np.arange(1, n_seg + 1)], axis=1)
    return pts, segs


def line(n_seg, x0, x1, y, rng=None, perturb=0.0):
    x = np.linspace(x0, x1, n_seg + 1)
    if rng is not None:
        h = (x1 - x0) / n_seg
        x[1:-1] += rng.uniform(-perturb * h, perturb * h, n_seg - 1)
    pts = np.stack([x, np.full_like(x, y)], axis=1)
    segs = np.stack([np.arange(n_seg), np.arange(1, n_seg + 1)], axis=1)
    return pts, segs


def row_sums(res: MortarContributions, n: int) -> np.ndarray:
    return np.bincount(res.m_rows, weights=res.m_vals, minlength=n)


def lumped(coords: np.ndarray, facets: np.ndarray) -> np.ndarray:
    """int phi_p over the slave surface (independent of the mortar code)."""
    x = coords[facets]
    if facets.shape[1] == 2:
        meas = np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
    else:
        meas = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    nv = facets.shape[1]
    return np.bincount(facets.ravel(), weights=np.repeat(meas / nv, nv), minlength=len(coords))


def point_in_triangle(tri, p, eps=1e-13):
    s = [cross2(tri[(i + 1) % 3] - tri[i], p - tri[i]) for i in range(3)]
    return all(v >= -eps for v in s) or all(v <= eps for v in s)


def reference_intersection_area(a: np.ndarray, b: np.ndarray) -> float:
    """Area of triangle ∩ triangle by an independent method: vertices of each inside
    the other plus edge/edge intersections, sorted by angle, shoelace."""
    pts = [p for p in a if point_in_triangle(b, p)] + [p for p in b if point_in_triangle(a, p)]
    for i, j in itertools.product(range(3), range(3)):
        p, r = a[i], a[(i + 1) % 3] - a[i]
        q, s = b[j], b[(j + 1) % 3] - b[j]
        den = cross2(r, s)
        if abs(den) < 1e-300:
            continue
        t = cross2(q - p, s) / den
        u = cross2(q - p, r) / den
        if 0.0 <= t <= 1.0 and 0.0 <= u <= 1.0:
            pts.append(p + t * r)
    if len(pts) < 3:
        return 0.0
    pts = np.array(pts)
    c = pts.mean(axis=0)
    pts = pts[np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0]))]
    return 0.5 * abs(np.sum(cross2(pts, np.roll(pts, -1, axis=0))))


def quadrature_triangle_pair_integrals(xs, ns, xm):
    """Mortar integrals of triangle pairs by quadrature at every point (the previous
    implementation, kept as a reference): orthogonal projection of the master into the
    slave's reference coordinates, clipping, centroid fan with the 7-point rule, master
    barycentrics, slave point, normalised interpolated normal and gap evaluated at each
    quadrature point.  Closed-form dual basis.

    Returns (area (P,), d (P, 3, 3), m (P, 3, 3), gap (P, 3)).
    """
    x0, a1, a2 = xs[:, 0], xs[:, 1] - xs[:, 0], xs[:, 2] - xs[:, 0]
    gram = np.stack(
        [
            np.stack([np.sum(a1 * a1, 1), np.sum(a1 * a2, 1)], 1),
            np.stack([np.sum(a1 * a2, 1), np.sum(a2 * a2, 1)], 1),
        ],
        1,
    )
    rhs = np.stack(
        [np.sum((xm - x0[:, None]) * a1[:, None], 2), np.sum((xm - x0[:, None]) * a2[:, None], 2)],
        2,
    )  # (P, 3, 2)
    mref = np.linalg.solve(gram[:, None], rhs[..., None])[..., 0]
    poly, count = clip_polygons_by_triangles(mref, np.full(len(xs), 3), np.eye(3)[:, 1:])
    qp, w = fan_quadrature(poly, count)
    w = w * np.sqrt(np.linalg.det(gram))[:, None]
    phi_s = shape_triangle(qp)
    e1, e2 = mref[:, 1] - mref[:, 0], mref[:, 2] - mref[:, 0]
    det = cross2(e1, e2)[:, None]
    rel = qp - mref[:, None, 0]
    l1 = cross2(rel, e2[:, None]) / det
    l2 = cross2(e1[:, None], rel) / det
    phi_m = np.stack([1.0 - l1 - l2, l1, l2], axis=-1)
    x = x0[:, None] + qp[..., :1] * a1[:, None] + qp[..., 1:] * a2[:, None]
    y = np.matmul(phi_m, xm)
    gap = np.sum((y - x) * normalise(np.matmul(phi_s, ns)), axis=-1)
    wpsi = w[..., None] * (phi_s @ DUAL_COEFFS_TRIANGLE.T)  # (P, Q, 3)
    return (
        w.sum(axis=1),
        np.einsum("pqj,pqk->pjk", wpsi, phi_s),
        np.einsum("pqj,pqk->pjk", wpsi, phi_m),
        np.einsum("pqj,pq->pj", wpsi, gap),
    )
