"""Regenerate the gmsh meshes shipped in data/scenes/.

    .venv/bin/python data/scenes/make_meshes.py

Writes ``long_bone.msh``: a 2D longitudinal section of a long-bone diaphysis
(0.2 m long, 0.03 m wide, 5 mm cortex, 4 mm metaphyseal flare, element size 1.6 mm,
about 3200 nodes, < 300 kB; cell groups "cortical", "cancellous"; facet groups "distal", "proximal",
"periosteum").
See :func:`bonecontact.meshing.anatomy.long_bone_2d`.

Writes ``knee2d.msh``: a 2D frontal section of the knee — femoral condyle (radius
30 mm; cartilage 3 mm, cortical 2 mm, cancellous core) in a concave tibial plateau (its
cartilage surface an arc of radius 40 mm through the origin, 68 mm wide, 50 mm deep below
the lowest point; cartilage 3 mm, subchondral plate 2 mm, cancellous, the layers
concentric), meshed separately (non-matching at the joint; 0.4 mm / 0.64 mm elements at
the contact).  The concave seat stands for the tibial cartilage together with the menisci,
which make the joint conform: on a flat plateau the 700 N contact was 12 mm wide and
strained the cartilage to 11.6 % (beyond the small-strain model), in the seat it is 19 mm
wide and strains it to 7 %.  See :func:`bonecontact.meshing.anatomy.knee_2d`.

Writes ``knee2d_tumour.msh``: the same knee with a 5 mm tumour disc (cell group
``tibia_tumour``) in the proximal tibia, centred 4 mm lateral, 20 mm below the plateau.

Writes ``jaw_cyst3d.msh``: a 30 x 16 x 16 mm block ("bone") with a 2 mm ball ("cyst") at
its centre, 0.5 mm elements at the cyst growing to 3 mm; facet groups "base" (z = 0)
and "occlusal" (z = 16 mm); see :func:`block_with_cyst`.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from pathlib import Path

from bonecontact.meshing.anatomy import knee_2d, long_bone_2d

#: The concave tibial seat of the 2D knee (m): radius of its cartilage surface, half width.
KNEE_PLATEAU = {"plateau_radius": 0.04, "plateau_half_width": 0.034}

HERE = Path(__file__).resolve().parent


def block_with_cyst(path: Path, h_in: float = 5e-4, h_out: float = 3e-3) -> Path:
    """The 3D block of ``jaw_cyst3d.toml`` with its cyst (gmsh, OCC)."""
    import gmsh

    from bonecontact.meshing.session import gmsh_session

    a, b, c, r = 0.03, 0.016, 0.016, 0.002
    with gmsh_session("jaw_cyst3d"):
        occ = gmsh.model.occ
        box, ball = occ.addBox(0, 0, 0, a, b, c), occ.addSphere(a / 2, b / 2, c / 2, r)
        _, m = occ.fragment([(3, box)], [(3, ball)])
        occ.synchronize()
        inner = [t for _, t in m[1]]
        outer = [t for _, t in m[0] if t not in inner]
        gmsh.model.addPhysicalGroup(3, outer, 1, name="bone")
        gmsh.model.addPhysicalGroup(3, inner, 2, name="cyst")
        faces = [abs(t) for _, t in gmsh.model.getBoundary([(3, t) for t in outer])]
        for tag, (name, z) in enumerate([("base", 0.0), ("occlusal", c)], start=3):
            pick = [f for f in faces if abs(occ.getCenterOfMass(2, f)[2] - z) < 1e-9]
            gmsh.model.addPhysicalGroup(2, pick, tag, name=name)
        f = gmsh.model.mesh.field
        d = f.add("Distance")
        f.setNumbers(
            d, "SurfacesList", [abs(t) for _, t in gmsh.model.getBoundary([(3, t) for t in inner])]
        )
        th = f.add("Threshold")
        f.setNumber(th, "InField", d)
        f.setNumber(th, "SizeMin", h_in)
        f.setNumber(th, "SizeMax", h_out)
        f.setNumber(th, "DistMin", 0.0)
        f.setNumber(th, "DistMax", 0.006)
        f.setAsBackgroundMesh(th)
        for key in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{key}", 0)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
    return path


def write_knees() -> None:
    """``knee2d.msh`` and ``knee2d_tumour.msh``."""
    path = knee_2d(path=HERE / "knee2d.msh", **KNEE_PLATEAU)
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")
    path = knee_2d(path=HERE / "knee2d_tumour.msh", tumour=(0.004, -0.02, 0.005), **KNEE_PLATEAU)
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")


def main() -> None:
    path = long_bone_2d(HERE / "long_bone.msh", h=1.6e-3)
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")
    write_knees()
    path = block_with_cyst(HERE / "jaw_cyst3d.msh")
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")


if __name__ == "__main__":
    main()
