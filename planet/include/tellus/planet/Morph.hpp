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
 * stay watertight. The drawn position is position + f x morphDelta.
 *
 * Edges morph too, and stay watertight because a shared vertex gets the same morph on both sides:
 *  - two same-level neighbours: the same position, the same chord along the side (the offset),
 *    and the same extent, bit for bit;
 *  - a side whose neighbour is coarser along it (edge fixing, Terrain.hpp): the finer side's
 *    vertices take the coarse node's morph as it draws it (EdgeAdapt::coarseMorph; between two
 *    coarse vertices the chord's, interpolated), and the zero-area triangles' copies of coarse
 *    vertices theirs, so the fans stay closed whatever the factors;
 *  - two nodes one level apart at the same resolution along a side (near the poles a row of nodes
 *    merged across longitudes, span 2 at level L + 1, beside level-L nodes of the same width): a
 *    side's vertices take the extent of the side's own span along it (morphEdgeExtent), not the
 *    node's level, so both give it the level-L extent. Chord and position agree already.
 * A polar cap does not morph, nor a node's vertices on a cap's rim (Terrain.cpp).
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

/** The morph targets of a square grid (mesh.rows == mesh.n; the first n x n vertices), see the
 * file comment; every grid vertex's morphExtentM set to extentM, except on the south and north
 * rows (the sides along a parallel): rowEdgeExtentM, the extent of the span along them
 * (morphEdgeExtent). Precondition: n odd (2^k + 1). */
void setGridMorph(TerrainMesh& mesh, double extentM, double rowEdgeExtentM);

/** The extent a side's vertices morph with: extentM (the node's, from its latitude span) times
 * the side's span along it over the node's latitude span, so a function of the side alone (its
 * span and the level's vertex count): a west or east side (along a meridian) keeps extentM, a
 * south or north side of a node merged across longitudes (span k) gets k x extentM. 0 stays 0. */
double morphEdgeExtent(double extentM, const Sector& node, bool alongParallel) noexcept;

} // namespace tellus::planet
