"""Regenerate the gmsh meshes shipped in data/scenes/.

    .venv/bin/python data/scenes/make_meshes.py

Writes ``long_bone.msh``: a 2D longitudinal section of a long-bone diaphysis
(0.2 m long, 0.03 m wide, 5 mm cortex, 4 mm metaphyseal flare, element size 1.6 mm,
about 3200 nodes, < 300 kB; cell groups "cortical", "cancellous"; facet groups "distal", "proximal",
"periosteum").
See :func:`bonecontact.meshing.anatomy.long_bone_2d`.

Writes ``knee2d.msh``: a 2D frontal section of the knee — femoral condyle (radius
30 mm; cartilage 3 mm, cortical 2 mm, cancellous core) on the tibial plateau (90 mm wide,
50 mm deep; cartilage, subchondral plate, cancellous), meshed separately (non-matching
at the joint; 0.4 mm / 0.64 mm elements at the contact).  See
:func:`bonecontact.meshing.anatomy.knee_2d`.

Writes ``knee2d_tumour.msh``: the same knee with a 5 mm tumour disc (cell group
``tibia_tumour``) in the proximal tibia, centred 4 mm lateral, 20 mm below the plateau.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from pathlib import Path

from bonecontact.meshing.anatomy import knee_2d, long_bone_2d

HERE = Path(__file__).resolve().parent


def main() -> None:
    path = long_bone_2d(HERE / "long_bone.msh", h=1.6e-3)
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")
    path = knee_2d(path=HERE / "knee2d.msh")
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")
    path = knee_2d(path=HERE / "knee2d_tumour.msh", tumour=(0.004, -0.02, 0.005))
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB)")


if __name__ == "__main__":
    main()
