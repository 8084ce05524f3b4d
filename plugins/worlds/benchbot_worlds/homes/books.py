"""Closed books made in code for BEAR's ``book`` cuboids (pure NumPy; the meshes are
:class:`~benchbot_worlds.scene.meshes.MeshData`).

A BEAR ``book`` object with ``isgroup`` is ONE ground-truth cuboid for a row or a stack of books; without it, one
book, unless no book could be that thick (:data:`ONE_BOOK_MAX_THICKNESS_M`). :func:`closed_books` fills such a
cuboid with closed books as a person sees them on a shelf or a table:

* a **row** of standing books (a cuboid at least as tall as it is deep, ``isgroup``): along the cuboid's long
  horizontal axis, seeded spine widths (about :data:`BOOK_THICKNESS_M`), heights and depths, the spines flush at the
  front (toward the room), the shorter books stopping short of the back;
* a **stack** of lying books (a flatter ``isgroup`` cuboid): a neat pile, about :data:`LYING_BOOK_THICKNESS_M`
  a book, seeded thicknesses and footprints (0.92..1 of the cuboid's), the larger books lower, every spine toward
  the room;
* a single book standing (taller than its shorter horizontal side, its thickness along that side) or lying.

Every book is a box of 12 triangles: its spine a coloured, textured face with a light title band and thin bands near
its ends (:data:`SPINE_COLOURS_SRGB`, :data:`BAND_COLOURS_SRGB`), its covers plain in the spine's colour, its three
page edges cream (:data:`PAGE_SRGB`) with fine page lines and the covers' edges as thin coloured lines. A book's
style (spine colour and band) is drawn per book, never the same colour twice in a row. The books' union is exactly
the cuboid (their bounds meet its six faces), no two overlap, each rests on the cuboid's bottom or on the book below
it; the same ``rng`` state gives the same books. The ground truth is not changed.

Meshes (:func:`closed_book_mesh`) are unit books in a model's map frame (x and y in −0.5..0.5, z in 0..1, the spine
at −y, the model's front) shared by every book of a style, stretched into each book's box by
:func:`~benchbot_worlds.homes.fitting.fit_to_cuboid`.
"""

from __future__ import annotations

import functools

import numpy as np

from benchbot_worlds.homes.fitting import fit_to_cuboid, turns_facing
from benchbot_worlds.scene.meshes import Material, MeshData, quad_mesh

__all__ = ["BOOK_THICKNESS_M", "MAX_BOOKS_PER_GROUP", "ONE_BOOK_MAX_THICKNESS_M", "book_boxes", "book_layout",
           "closed_book_mesh", "closed_books"]

#: Typical thickness (m) of a standing book: a row has about one spine per this along its length (each seeded
#: 0.7..1.3 times the mean).
BOOK_THICKNESS_M = 0.03
#: Typical thickness (m) of a lying book: a stack has about one book per this in height. Thicker than a row's: with
#: 3 cm books the detector of ``benchmarks/realism.py`` boxed single books of a stack, not the stack
#: (docs/realism.md, 25 Nov 2026).
LYING_BOOK_THICKNESS_M = 0.04
#: The thickest one book can be (m): a large dictionary is about 8 cm thick. A ``book`` cuboid with no extent this
#: thin cannot be one book, whatever its ``isgroup`` says, and is filled as a row or a stack (:func:`book_layout`).
#: BEAR's single books are 3.6-4.9 cm at their thinnest; the procedural homes draw each book's size from all of BEAR's
#: book cuboids, most of them rows and stacks (median 0.25 x 0.29 x 0.13 m), and mark it one book.
ONE_BOOK_MAX_THICKNESS_M = 0.08
#: The smallest fraction of a stack's footprint (per axis) a book of it covers: a neat pile.
STACK_FOOTPRINT_MIN = 0.92
#: The most books in one row or stack.
MAX_BOOKS_PER_GROUP = 40
#: sRGB colours of spines and covers: cloth and paper bindings of real books.
SPINE_COLOURS_SRGB = (
    (0.55, 0.08, 0.08), (0.12, 0.18, 0.42), (0.10, 0.32, 0.20), (0.08, 0.08, 0.09), (0.40, 0.24, 0.12),
    (0.85, 0.82, 0.72), (0.80, 0.40, 0.10), (0.78, 0.62, 0.18), (0.35, 0.55, 0.72), (0.45, 0.45, 0.47),
    (0.38, 0.10, 0.22), (0.08, 0.40, 0.42), (0.30, 0.18, 0.42), (0.88, 0.88, 0.86), (0.70, 0.20, 0.18),
    (0.20, 0.28, 0.20))
#: sRGB colours of a spine's title band and end bands (cream, gold, white, black).
BAND_COLOURS_SRGB = ((0.90, 0.86, 0.72), (0.80, 0.64, 0.28), (0.95, 0.95, 0.93), (0.07, 0.07, 0.08))
#: sRGB colour of the page edges.
PAGE_SRGB = (0.92, 0.89, 0.80)
#: Roughness of covers and pages.
BOOK_ROUGHNESS = 0.75
#: Bounds of the unit book of :func:`closed_book_mesh` (its model frame).
UNIT_BOUNDS = np.array([[-0.5, -0.5, 0.0], [0.5, 0.5, 1.0]])
#: Texture sizes: spine (rows along the spine's length, columns across the book's thickness), page edges (rows along
#: the edge, columns across the thickness), cover (rows along the book's height, columns across its width).
_SPINE_PX = (64, 16)
_PAGE_PX = (32, 32)
_COVER_PX = (48, 32)


def book_layout(ext: np.ndarray, isgroup: bool) -> tuple[str, int]:
    """How a book cuboid of extents ``ext`` (3,) metres is filled: (``"row"`` | ``"stack"`` | ``"standing"`` |
    ``"lying"``, number of books). A group at least as tall as its shorter horizontal side is a row of about
    ``long side / BOOK_THICKNESS_M`` standing books, a flatter group a stack of about
    ``height / LYING_BOOK_THICKNESS_M`` lying books (1 to :data:`MAX_BOOKS_PER_GROUP`); a single book stands when it is
    taller than its shorter horizontal side, else it lies. A cuboid thicker than :data:`ONE_BOOK_MAX_THICKNESS_M`
    along every axis is a group whatever ``isgroup`` says (no book is that thick)."""
    ext = np.asarray(ext, dtype=np.float64)
    upright = ext[2] >= min(ext[0], ext[1])
    if not isgroup and ext.min() <= ONE_BOOK_MAX_THICKNESS_M:
        return ("standing" if ext[2] > min(ext[0], ext[1]) else "lying"), 1
    if upright:
        n = int(np.clip(round(max(ext[0], ext[1]) / BOOK_THICKNESS_M), 1, MAX_BOOKS_PER_GROUP))
        return "row", n
    return "stack", int(np.clip(round(ext[2] / LYING_BOOK_THICKNESS_M), 1, MAX_BOOKS_PER_GROUP))


def _seeded_parts(rng: np.random.Generator, lo: float, hi: float, n: int, low_a: float,
                  low_b: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The seeded split of ``[lo, hi]`` (metres) into ``n`` parts: ``(edges (n + 1,) float64, from ``lo`` to ``hi``
    exactly, part widths uniform in 0.7..1.3 relative, fa (n,), fb (n,))``, two size fractions per part uniform in
    ``low_a``..1 and ``low_b``..1, one part of each set to 1 (in this order of draws from ``rng``)."""
    t = rng.uniform(0.7, 1.3, n)
    edges = lo + (hi - lo) * np.concatenate([[0.0], np.cumsum(t) / t.sum()])
    edges[-1] = hi
    fa, fb = rng.uniform(low_a, 1.0, n), rng.uniform(low_b, 1.0, n)
    fa[int(rng.integers(n))] = 1.0
    fb[int(rng.integers(n))] = 1.0
    return edges, fa, fb


def book_boxes(lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator, front_sign: float, mode: str,
               n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Boxes ``(lo (3,), hi (3,))`` metres of the ``n`` books of a cuboid ``lo``..``hi`` (see :func:`book_layout`):
    ``"row"``: along the long horizontal axis, seeded widths, heights (0.72..1 of the cuboid's) and depths (0.8..1),
    spines flush at the front (the cuboid's side toward ``front_sign`` on the other horizontal axis); ``"stack"``:
    seeded thicknesses and footprints (:data:`STACK_FOOTPRINT_MIN`..1 of the cuboid's on each axis, seeded
    offsets), the footprints sorted by area, largest at the bottom. Union bounds = the cuboid; boxes do not overlap;
    one box for ``n`` = 1."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    ext = hi - lo
    u = 0 if ext[0] >= ext[1] else 1
    w = 1 - u
    if n == 1:
        return [(lo.copy(), hi.copy())]
    if mode == "stack":
        edges, fu, fw = _seeded_parts(rng, lo[2], hi[2], n, STACK_FOOTPRINT_MIN, STACK_FOOTPRINT_MIN)
        feet = []
        for i in range(n):
            blo, bhi = lo.copy(), hi.copy()
            for ax, f in ((u, fu[i]), (w, fw[i])):
                off = rng.uniform(0.0, 1.0 - f) * ext[ax]
                blo[ax] = lo[ax] + off if f < 1.0 else lo[ax]
                bhi[ax] = blo[ax] + f * ext[ax] if f < 1.0 else hi[ax]
            feet.append((blo, bhi))
        feet.sort(key=lambda b: -float(np.prod((b[1] - b[0])[:2])))
        out = []
        for i, (blo, bhi) in enumerate(feet):
            blo[2], bhi[2] = edges[i], edges[i + 1]
            out.append((blo, bhi))
        return out
    edges, fh, fd = _seeded_parts(rng, lo[u], hi[u], n, 0.72, 0.8)
    out = []
    for i in range(n):
        blo, bhi = lo.copy(), hi.copy()
        blo[u], bhi[u] = edges[i], edges[i + 1]
        if fd[i] < 1.0:  # spines flush at the front (hi[w] if front_sign > 0), shorter books stop short of the back
            if front_sign > 0:
                blo[w] = hi[w] - fd[i] * ext[w]
            else:
                bhi[w] = lo[w] + fd[i] * ext[w]
        bhi[2] = lo[2] + fh[i] * ext[2] if fh[i] < 1.0 else hi[2]
        out.append((blo, bhi))
    return out


# ----------------------------------------------------------------------------------------------------- the meshes
def _srgb8(rgb) -> np.ndarray:
    return np.clip(np.round(np.asarray(rgb, dtype=np.float64) * 255.0), 0, 255).astype(np.uint8)


def _ink(colour: int, band: int) -> np.ndarray:
    """sRGB (3,) of a style's lettering: its band colour, or the next band colour where that is too near the
    spine's."""
    base = np.asarray(SPINE_COLOURS_SRGB[colour], dtype=np.float64)
    for j in range(len(BAND_COLOURS_SRGB)):
        ink = np.asarray(BAND_COLOURS_SRGB[(band + j) % len(BAND_COLOURS_SRGB)], dtype=np.float64)
        if np.abs(ink - base).sum() >= 0.6:
            return ink
    return 1.0 - base


def _spine_texture(colour: int, band: int) -> np.ndarray:
    """(64, 16, 3) uint8 sRGB spine: rows along the spine (row 0 at its top end, ``v`` = 1), columns across it. The
    spine colour, shaded darker toward its edges (a rounded spine); a title running along its middle (blocks of
    letters in the lettering colour, :func:`_ink`) over a seeded part of its length, a short author's or
    publisher's block near its bottom end, thin bands across it near both ends (every other band style)."""
    rows, cols = _SPINE_PX
    base = np.asarray(SPINE_COLOURS_SRGB[colour], dtype=np.float64)
    ink = _ink(colour, band)
    img = np.tile(base, (rows, cols, 1))
    start = 8 + (colour * 5 + band * 3) % 10  # the title: rows start..end, columns 5..10, letters 3 rows, 1 apart
    end = start + 22 + (colour * 3 + band * 7) % 14
    letters = (np.arange(rows) - start) % 4 != 3
    img[start:end, 5:11][letters[start:end]] = ink
    img[rows - 13:rows - 8, 6:10] = ink
    if band % 2 == 0:
        img[3:5] = ink
        img[rows - 5:rows - 3] = ink
    across = np.linspace(-1.0, 1.0, cols)
    img *= (1.05 - 0.3 * across ** 4)[None, :, None]
    return _srgb8(img)


def _page_texture(colour: int) -> np.ndarray:
    """(32, 32, 3) uint8 sRGB page edge: cream with fine page lines across the thickness (columns), the covers' edges
    (two columns at either side) in the spine colour."""
    rows, cols = _PAGE_PX
    shade = 1.0 - 0.06 * ((np.arange(cols) * 7919) % 5 == 0)  # fine page lines
    img = np.tile(np.asarray(PAGE_SRGB, dtype=np.float64), (rows, cols, 1)) * shade[None, :, None]
    img[:, :2] = SPINE_COLOURS_SRGB[colour]
    img[:, cols - 2:] = SPINE_COLOURS_SRGB[colour]
    return _srgb8(img)


def _cover_texture(colour: int, band: int) -> np.ndarray:
    """(48, 32, 3) uint8 sRGB front cover: rows along the book's height (row 0 at its top, ``v`` = 1), columns across
    its width; the spine colour with a title panel in the band colour in its upper half and a thin frame line."""
    rows, cols = _COVER_PX
    base = np.asarray(SPINE_COLOURS_SRGB[colour], dtype=np.float64)
    ink = _ink(colour, band)
    img = np.tile(base, (rows, cols, 1))
    img[3, 3:cols - 3] = img[rows - 4, 3:cols - 3] = ink
    img[3:rows - 3, 3] = img[3:rows - 3, cols - 4] = ink
    img[9 + band:19 + band, 7:cols - 7] = ink
    return _srgb8(img)


@functools.lru_cache(maxsize=None)
def _materials(colour: int, band: int) -> tuple[Material, Material, Material]:
    """(spine, cover, pages) of a style: shared by every book of it (one material each in a scene)."""
    white = np.ones(3, np.float32)
    return (Material(albedo=white, texture=_spine_texture(colour, band), roughness=BOOK_ROUGHNESS,
                     name=f"book_spine:{colour}:{band}", from_file=False),
            Material(albedo=white, texture=_cover_texture(colour, band), roughness=BOOK_ROUGHNESS,
                     name=f"book_cover:{colour}:{band}", from_file=False),
            Material(albedo=white, texture=_page_texture(colour), roughness=BOOK_ROUGHNESS,
                     name=f"book_pages:{colour}", from_file=False))


@functools.lru_cache(maxsize=None)
def closed_book_mesh(colour: int, band: int, lying: bool) -> MeshData:
    """The unit closed book of a style (``colour`` index into :data:`SPINE_COLOURS_SRGB`, ``band`` into
    :data:`BAND_COLOURS_SRGB`): a box ``x, y`` in −0.5..0.5, ``z`` in 0..1 (:data:`UNIT_BOUNDS`) whose −y face is the
    spine (textured: ``u`` across the thickness, ``v`` along the spine). Standing (``lying`` False): thickness along
    x, covers the ±x faces, page edges the +y, top and bottom faces. Lying: thickness along z, spine along x, covers
    the top and bottom faces, page edges the +y and ±x faces. 24 vertices, 12 triangles, 3 materials, flat normals;
    cached (one mesh per style)."""
    spine, cover, pages = range(3)
    # each face: corners in the unit box (counter-clockwise seen from outside), outward normal, material, uv of a
    # corner p (u across the book's thickness on the spine and page edges)
    def zx(p):
        return p[2], p[0] + .5

    def zy(p):
        return p[2], p[1] + .5

    def xy(p):
        return p[0] + .5, p[1] + .5

    def yx(p):
        return p[1] + .5, p[0] + .5

    def xz(p):
        return p[0] + .5, p[2]

    def yz(p):
        return p[1] + .5, p[2]

    if lying:
        faces = [
            ([(-.5, -.5, 0), (.5, -.5, 0), (.5, -.5, 1), (-.5, -.5, 1)], (0, -1, 0), spine, zx),
            ([(.5, .5, 0), (-.5, .5, 0), (-.5, .5, 1), (.5, .5, 1)], (0, 1, 0), pages, zx),
            ([(.5, -.5, 0), (.5, .5, 0), (.5, .5, 1), (.5, -.5, 1)], (1, 0, 0), pages, zy),
            ([(-.5, .5, 0), (-.5, -.5, 0), (-.5, -.5, 1), (-.5, .5, 1)], (-1, 0, 0), pages, zy),
            ([(-.5, -.5, 1), (.5, -.5, 1), (.5, .5, 1), (-.5, .5, 1)], (0, 0, 1), cover, yx),
            ([(-.5, .5, 0), (.5, .5, 0), (.5, -.5, 0), (-.5, -.5, 0)], (0, 0, -1), cover, yx),
        ]
    else:
        faces = [
            ([(-.5, -.5, 0), (.5, -.5, 0), (.5, -.5, 1), (-.5, -.5, 1)], (0, -1, 0), spine, xz),
            ([(.5, .5, 0), (-.5, .5, 0), (-.5, .5, 1), (.5, .5, 1)], (0, 1, 0), pages, xz),
            ([(-.5, -.5, 1), (.5, -.5, 1), (.5, .5, 1), (-.5, .5, 1)], (0, 0, 1), pages, xy),
            ([(-.5, .5, 0), (.5, .5, 0), (.5, -.5, 0), (-.5, -.5, 0)], (0, 0, -1), pages, xy),
            ([(.5, -.5, 0), (.5, .5, 0), (.5, .5, 1), (.5, -.5, 1)], (1, 0, 0), cover, yz),
            ([(-.5, .5, 0), (-.5, -.5, 0), (-.5, -.5, 1), (-.5, .5, 1)], (-1, 0, 0), cover, yz),
        ]
    return quad_mesh(faces, list(_materials(colour, band)))


def closed_books(lo: np.ndarray, hi: np.ndarray, *, isgroup: bool, away: np.ndarray | None,
                 rng: np.random.Generator) -> list[tuple[MeshData, np.ndarray]]:
    """The closed books that fill a book cuboid ``lo``..``hi`` (3,) metres (see the module docstring).

    Args:
        lo, hi: the ground-truth cuboid's corners (positive extents).
        isgroup: BEAR's ``isgroup`` (a row or a stack) or one book.
        away: (2,) unit axis direction from the nearest wall into the room, or None. Spines face it: a standing
            book's where it lies across the book's thickness (else a seeded side of the two), a lying book's always
            (a seeded one of the four sides without it; one side for the whole stack).
        rng: seeded; the same state gives the same books.

    Returns:
        ``[(mesh, transform (4, 4) float64)]``: each book's unit mesh (:func:`closed_book_mesh`) and the transform
        that puts its :data:`UNIT_BOUNDS` exactly onto the book's box (:func:`book_boxes`).
    """
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    ext = hi - lo
    mode, n = book_layout(ext, isgroup)
    lying = mode in ("stack", "lying")
    w = 1 if ext[0] >= ext[1] else 0  # the axis a row's spines face (across the books' thickness)
    if mode == "standing":  # one standing book: thickness along the shorter horizontal side, spine across it
        w = 1 - w
    away = None if away is None else np.asarray(away, dtype=np.float64)[:2]
    if away is not None and (lying or abs(away[w]) > 0.5):
        front = away
    elif lying:
        front = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])[int(rng.integers(4))]
    else:
        front = np.eye(2)[w] * (1.0 if rng.random() < 0.5 else -1.0)
    front_sign = 1.0 if front[w] >= 0 else -1.0
    k_front = turns_facing(front)
    out, last = [], -1
    for blo, bhi in book_boxes(lo, hi, rng, front_sign, mode, n):
        if last < 0:
            colour = int(rng.integers(len(SPINE_COLOURS_SRGB)))
        else:  # never the colour of the book before
            colour = int(rng.integers(len(SPINE_COLOURS_SRGB) - 1))
            colour += colour >= last
        last = colour
        band = int(rng.integers(len(BAND_COLOURS_SRGB)))
        mesh = closed_book_mesh(colour, band, lying)
        out.append((mesh, fit_to_cuboid(None, blo, bhi, k_front, bounds=UNIT_BOUNDS)))
    return out
