#pragma once
// glTF 2.0 binary (.glb) point clouds and triangle meshes (the `points.glb` and `mesh.glb`
// outputs of `omnipoint predict`), which any glTF viewer opens: one mesh with one primitive,
// attributes POSITION (float32 VEC3, with the min/max glTF requires) and COLOR_0 (normalised
// unsigned byte VEC4, alpha 255; VEC4 keeps every element 4-byte aligned as glTF requires of
// vertex data). Point clouds: mode POINTS (0). Meshes: mode TRIANGLES (4), `indices` an
// unsigned int (5125) SCALAR accessor on an ELEMENT_ARRAY_BUFFER view after the vertex data,
// and a double-sided, non-metallic material so that the vertex colours show from both sides.
//
// File layout (glTF 2.0 spec, "GLB File Format"): a 12-byte header (magic "glTF", version 2,
// total length), a JSON chunk (type "JSON", padded with spaces to a multiple of 4 bytes) and
// a BIN chunk (type "BIN\0", padded with zeros to a multiple of 4). All little-endian.
//
// glTF is y up with the viewer looking along −z; the points are taken in our camera frame
// (x right, y down, z forward) and stored as (x, −y, −z), so a viewer's default camera sees
// the scene as the image does (a rotation: the triangles' winding is kept). An empty cloud or
// mesh gives a scene with a node but no mesh.
#include <ATen/core/Tensor.h>

#include <string>

namespace omnipoint::io {

// points (N, 3) any floating dtype (stored as float32), colors (N, 3) uint8 or undefined
// (white). Bad shapes or dtypes, non-finite points -> std::invalid_argument.
std::string encode_glb_points(const at::Tensor& points, const at::Tensor& colors = {});
// Writes encode_glb_points(...) to `path` atomically.
void write_glb_points(const std::string& path, const at::Tensor& points,
                      const at::Tensor& colors = {});

// A triangle mesh: vertices and colors as for points, faces (T, 3) integer indices into the
// vertices, counter-clockwise front faces. Bad shapes, indices out of range -> invalid_argument.
std::string encode_glb_mesh(const at::Tensor& vertices, const at::Tensor& colors,
                            const at::Tensor& faces);
void write_glb_mesh(const std::string& path, const at::Tensor& vertices, const at::Tensor& colors,
                    const at::Tensor& faces);

}  // namespace omnipoint::io
