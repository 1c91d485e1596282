"""Checks of a scene against its mesh (physical-group names, dimensions, overlaps).

:func:`check_against_mesh` runs, once the mesh has been read, every check that needs the
mesh's physical groups; each problem is a :class:`~bonecontact.scene.errors.SceneError`
naming the file, the table and the key, and listing the available names of the right
dimension.
"""

from __future__ import annotations

from collections.abc import Mapping

from bonecontact.scene.errors import SceneError, table_label
from bonecontact.scene.spec import LOAD_KINDS, Scene

__all__ = ["MeshGroups", "check_against_mesh"]


class MeshGroups:
    """The physical groups of a mesh, looked up on behalf of a scene file.

    Parameters
    ----------
    file
        The scene file (for messages).
    groups
        Physical-group name → ``(dim, tag)``.
    tdim
        Topological dimension of the mesh (cells); facets have ``tdim - 1``.
    """

    def __init__(self, file: str, groups: Mapping[str, tuple[int, int]], tdim: int):
        self.file = file
        self.groups = groups
        self.tdim = tdim
        self.fdim = tdim - 1

    def available(self, dim: int) -> str:
        """The names of the groups of dimension ``dim``, quoted, for messages."""
        names = sorted(n for n, (d, _) in self.groups.items() if d == dim)
        return ", ".join(f'"{n}"' for n in names) if names else "(none)"

    def require(self, name: str, dim: int, table: str, key: str) -> int:
        """The tag of group ``name``, which must exist and have dimension ``dim``."""
        kind = "cell" if dim == self.tdim else "facet"
        if name not in self.groups:
            raise SceneError(
                self.file,
                table,
                key,
                f'the mesh has no physical group "{name}"; '
                f"its {kind} groups are: {self.available(dim)}",
            )
        d, tag = self.groups[name]
        if d != dim:
            other = {self.tdim: "cell", self.fdim: "facet"}.get(d, f"dimension-{d}")
            raise SceneError(
                self.file,
                table,
                key,
                f'"{name}" is a {other} group (dim {d}), a {kind} group '
                f"(dim {dim}) is needed; {kind} groups: {self.available(dim)}",
            )
        return tag

    def cell(self, name: str, table: str, key: str) -> int:
        """The tag of the cell group ``name``."""
        return self.require(name, self.tdim, table, key)

    def facet(self, name: str, table: str, key: str) -> int:
        """The tag of the facet group ``name``."""
        return self.require(name, self.fdim, table, key)


def check_against_mesh(
    scene: Scene, groups: Mapping[str, tuple[int, int]], tdim: int, gdim: int
) -> None:
    """Check the scene's physical-group names against the mesh.

    Parameters
    ----------
    scene
        A scene from :func:`~bonecontact.scene.reader.load_scene`.
    groups
        Physical-group name → ``(dim, tag)`` of the mesh.
    tdim, gdim
        Topological and geometric dimension of the mesh.

    Raises
    ------
    SceneError
        The mesh dimension differs from ``[scene].dimension``; a material,
        body-force or initial-velocity region is not a cell group (dim
        ``tdim``); a Dirichlet/load boundary or a contact surface is not a facet
        group (dim ``tdim - 1``); two materials claim the same cell group tag; a
        cell group has no material; two ``[[dirichlet]]`` entries fix the same
        component of the same boundary; a traction acts on a component that a
        ``[[dirichlet]]`` entry fixes on the same boundary; the ``[neoplasm]``
        region or a host group is not a cell group, or a host has the region's tag; the
        cyst region of a coupled scene has a material (it is a cavity and takes none).
        Messages list the available names of the right dimension.  A growth-only
        scene has no materials, so its cell groups need none.
    """
    check_dimension(scene, tdim, gdim)
    mesh = MeshGroups(str(scene.path), groups, tdim)
    owner = check_material_regions(scene, mesh)
    check_neoplasm_groups(scene, mesh)
    cavity = check_cyst_cavity(scene, mesh, owner)
    check_cells_have_material(scene, mesh, owner, cavity)
    check_contact_surfaces(scene, mesh)
    fixed = check_dirichlet_boundaries(scene, mesh)
    check_load_targets(scene, mesh, fixed)
    check_initial_velocity_regions(scene, mesh)


def check_dimension(scene: Scene, tdim: int, gdim: int) -> None:
    """The mesh's topological and geometric dimensions equal ``[scene].dimension``."""
    if tdim != scene.dimension or gdim != scene.dimension:
        raise SceneError(
            str(scene.path),
            "[scene]",
            "dimension",
            f"is {scene.dimension} but the mesh ({scene.mesh_path.name}) has topological "
            f"dimension {tdim} and geometric dimension {gdim}",
        )


def check_material_regions(scene: Scene, mesh: MeshGroups) -> dict[int, str]:
    """Material regions are cell groups, no two materials share a tag.

    Returns
    -------
    dict
        Cell group tag → name of its material.
    """
    owner: dict[int, str] = {}
    for m in scene.materials:
        label = table_label("material", m.index, m.name)
        for r in m.regions:
            tag = mesh.cell(r, label, "regions")
            if tag in owner and owner[tag] != m.name:
                raise SceneError(
                    mesh.file,
                    label,
                    "regions",
                    f'region "{r}" (tag {tag}) has the same cells as a region of material '
                    f'"{owner[tag]}"',
                )
            owner[tag] = m.name
    return owner


def check_neoplasm_groups(scene: Scene, mesh: MeshGroups) -> None:
    """The ``[neoplasm]`` region and hosts are cell groups; no host has the region's tag."""
    neo = scene.neoplasm
    if neo is None or neo.region is None:
        return
    rtag = mesh.cell(neo.region, "[neoplasm]", "region")
    for h in neo.host:
        if mesh.cell(h, "[neoplasm]", "host") == rtag:
            raise SceneError(
                mesh.file,
                "[neoplasm]",
                "host",
                f'"{h}" has the same cells (tag {rtag}) as the neoplasm region "{neo.region}"',
            )


def check_cyst_cavity(scene: Scene, mesh: MeshGroups, owner: Mapping[int, str]) -> str | None:
    """A coupled cyst (kind = "cyst" with ``[analysis]``) is a pressurised cavity: no material.

    Returns
    -------
    str or None
        The cyst region (a cavity of the mechanics), or ``None``.
    """
    neo = scene.neoplasm
    cavity = neo.region if neo is not None and neo.kind == "cyst" else None
    if cavity is not None and not scene.growth_only and mesh.groups[cavity][1] in owner:
        raise SceneError(
            mesh.file,
            "[[material]]",
            "regions",
            f'cell group "{cavity}" is the cyst of [neoplasm]: a pressurised cavity in the '
            f"mechanics, it takes no material; remove it from the regions of "
            f'"{owner[mesh.groups[cavity][1]]}"',
        )
    return cavity


def check_cells_have_material(
    scene: Scene, mesh: MeshGroups, owner: Mapping[int, str], cavity: str | None
) -> None:
    """Every cell group except the cyst cavity has a material (not needed without mechanics)."""
    if scene.growth_only:  # no mechanics: cell groups need no material
        return
    for name, (d, tag) in sorted(mesh.groups.items()):
        if d == mesh.tdim and tag not in owner and name != cavity:
            raise SceneError(
                mesh.file,
                "[[material]]",
                "regions",
                f'cell group "{name}" has no material; list it in the regions of a [[material]]',
            )


def check_contact_surfaces(scene: Scene, mesh: MeshGroups) -> None:
    """Contact slave and master are distinct facet groups."""
    for i, c in enumerate(scene.contacts):
        label = table_label("contact", i, c.name)
        s = mesh.facet(c.slave, label, "slave")
        if mesh.facet(c.master, label, "master") == s:
            raise SceneError(
                mesh.file, label, "master", f'"{c.master}" and "{c.slave}" are the same facet group'
            )


def check_dirichlet_boundaries(scene: Scene, mesh: MeshGroups) -> dict[tuple[int, int], int]:
    """Dirichlet boundaries are facet groups; each component of a boundary is fixed once.

    Returns
    -------
    dict
        ``(facet tag, component)`` → index of the ``[[dirichlet]]`` entry fixing it.
    """
    fixed: dict[tuple[int, int], int] = {}
    for i, bc in enumerate(scene.dirichlet):
        label = table_label("dirichlet", i)
        tag = mesh.facet(bc.boundary, label, "boundary")
        for comp in bc.components:
            if (tag, comp) in fixed:
                j = fixed[(tag, comp)]
                raise SceneError(
                    mesh.file,
                    label,
                    "value",
                    f'component {comp + 1} of boundary "{bc.boundary}" is already fixed by '
                    f'[[dirichlet]] #{j + 1} (boundary "{scene.dirichlet[j].boundary}"); '
                    "each component of a boundary may be fixed once",
                )
            fixed[(tag, comp)] = i
    return fixed


def check_load_targets(
    scene: Scene, mesh: MeshGroups, fixed: Mapping[tuple[int, int], int]
) -> None:
    """Body forces act on cell groups, tractions and pressures on facet groups; a
    traction loads only the free components of its boundary."""
    counters = {k: 0 for k in LOAD_KINDS}
    for load in scene.loads:
        label = table_label(load.kind, counters[load.kind])
        counters[load.kind] += 1
        if load.kind == "body_force":
            for r in load.target:
                mesh.cell(r, label, "regions")
            continue
        tag = mesh.facet(load.target[0], label, "boundary")
        if load.kind == "traction":
            assert isinstance(load.value, tuple)
            for comp, v in enumerate(load.value):
                if v != 0.0 and (tag, comp) in fixed:
                    raise SceneError(
                        mesh.file,
                        label,
                        "value",
                        f'component {comp + 1} of boundary "{load.target[0]}" is fixed by '
                        f"[[dirichlet]] #{fixed[(tag, comp)] + 1}; a boundary carries loads only "
                        "in its free components",
                    )


def check_initial_velocity_regions(scene: Scene, mesh: MeshGroups) -> None:
    """Initial-velocity regions are cell groups."""
    for i, iv in enumerate(scene.initial_velocities):
        label = table_label("initial_velocity", i)
        for r in iv.regions:
            mesh.cell(r, label, "regions")
