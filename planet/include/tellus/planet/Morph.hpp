#pragma once
/**
 * @file Morph.hpp
 * @brief Geomorphing (issue 23, "No popping"; thesis 6.2.2): a node's vertices blend between their
 * own positions and where the parent's coarser mesh puts them, so that a split or a merge moves
 * heights continuously instead of at once. GL-free; shaders/planet.vert does the blend per vertex.
 *
 * Morph targets (setGridMorph): the parent's grid (the same n x n over twice the sector) holds the
 * child's even vertices (row and column even) exactly, and draws the rest on its triangles: an odd
 * vertex of an even row or column lies on the chord between its two even neighbours along it, an
 * odd-odd vertex on the parent cell's south-west to north-east diagonal (gridCells' a-e split),
 * i.e. the middle of its south-west and north-east neighbours. Heights are a pure function of the
 * tiles held (Terrain.hpp), so these are the parent's very vertices and chords. A vertex carries
 * its target as an offset from its position (TerrainVertex::morphDelta, metres, ECEF) and the
 * parent's north-south extent (TerrainVertex::morphExtentM, metres along the meridian), which
 * depends on the level alone: two same-level neighbours give a shared vertex the same pair.
 *
 * Morph factor (morphFactor): the parent splits when one of its texels, north-south extent E /
 * tileHeightPx metres, projects larger than the LOD threshold, i.e. at a distance up to
 * D = E x scale with scale = focalPx / (threshold x tileHeightPx) (morphScale; face-on, the
 * corner test of Lod.hpp), and the node itself splits at about D / 2. Over that life the factor
 * goes from 1 (the parent's positions) at d >= D to 0 (its own) at d <= D / 2, linearly in the
 * vertex's distance d from the eye: f = clamp(2 d / D - 1, 0, 1). A function of the vertex's
 * position, its extent and the camera only, so every node holding a vertex (its neighbours, a
 * finer node's copy of a coarse vertex in its zero-area triangles) morphs it identically and edges
 * stay watertight. The drawn position is position + f x morphDelta. The renderer pins every
 * node's boundary (pinMorphBoundary): the interior morphs, edges are drawn as without morphing.
 */

#include <tellus/planet/Geodesy.hpp>
#include <tellus/planet/Terrain.hpp>

#include <glm/vec3.hpp>

namespace tellus::planet {

/** 1 / (pixels of one metre of texel at one metre of distance): focalPx / (threshold x
 * tileHeightPx). focalPx: the perspective's focal length in pixels ((height / 2) / tan(vfov / 2))
 * or the fisheye's pixels per radian. 0 for invalid input (morphFactor then gives 1 nowhere: 0). */
double morphScale(double focalPx, double threshold, int tileHeightPx) noexcept;

/** The morph factor of a vertex distanceM from the eye whose parent's north-south extent is
 * extentM: clamp(2 d / (extentM x scale) - 1, 0, 1); 0 when extentM x scale is not > 0 (no
 * morph: a root, a cap, geomorphing off) or the input is not finite. */
double morphFactor(double distanceM, double extentM, double scale) noexcept;

/** The parent's north-south extent in metres of a node of this sector (twice its latitude span,
 * along a meridian of the equatorial radius: a function of the level alone). */
double morphExtentOf(const Geodesy& geodesy, const Sector& sector) noexcept;

/** Zeroes the morph offset of every vertex on the grid's boundary and of the vertices past the
 * grid (the zero-area triangles' coarse vertices): only a node's interior morphs, so every edge is
 * drawn exactly as without geomorphing and stays watertight with the edge fixing alone. Why: two
 * nodes of different levels can share an edge at the same resolution (merged polar rows: a level
 * L + 1 node two columns wide beside a level-L one), where the same vertex would get two parents'
 * extents, two factors and a crack (seen near the poles in TerrainMorphViewGl); an edge vertex
 * also pops less than an interior one (it lies on both nodes' chords along the edge). */
void pinMorphBoundary(TerrainMesh& mesh);

/** The morph targets of a square grid (mesh.rows == mesh.n; the first n x n vertices), see the
 * file comment; every grid vertex's morphExtentM set to extentM. Precondition: n odd (2^k + 1). */
void setGridMorph(TerrainMesh& mesh, double extentM);

} // namespace tellus::planet
