#!/usr/bin/env python3
"""Writes the first mesh of a GLB (positions and triangle indices) in another format, for the
import benchmark: the same triangles as binary PLY, ASCII PLY, binary STL, OBJ or OFF.

Usage: bench/mesh_convert.py IN.glb OUT.{ply,stl,obj,off} [--ascii]

Python's standard library only (no numpy): whole arrays go through `array` and strided
bytearray slices, so a 4 M-triangle binary PLY takes seconds, not minutes; the text formats
are written line by line and are slower.
"""
import array
import json
import struct
import sys


def read_glb(path):
    data = open(path, "rb").read()
    json_length, = struct.unpack_from("<I", data, 12)
    gltf = json.loads(data[20:20 + json_length])
    binary = 20 + json_length + 8

    def accessor(index):
        a = gltf["accessors"][index]
        view = gltf["bufferViews"][a["bufferView"]]
        start = binary + view.get("byteOffset", 0) + a.get("byteOffset", 0)
        width = {"SCALAR": 1, "VEC3": 3}[a["type"]]
        values = array.array({5126: "f", 5125: "I", 5123: "H"}[a["componentType"]])
        values.frombytes(data[start:start + a["count"] * width * values.itemsize])
        if sys.byteorder != "little":
            values.byteswap()
        return values

    primitive = gltf["meshes"][0]["primitives"][0]
    positions = accessor(primitive["attributes"]["POSITION"])
    indices = array.array("I", accessor(primitive["indices"]))
    return positions, indices


def little_endian(values):
    if sys.byteorder != "little":
        values = array.array(values.typecode, values)
        values.byteswap()
    return values.tobytes()


def write_binary_ply(out, positions, indices):
    faces = len(indices) // 3
    out.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(positions) // 3}\nproperty float x\n"
              f"property float y\nproperty float z\nelement face {faces}\nproperty list uchar int vertex_indices\n"
              "end_header\n".encode())
    out.write(little_endian(positions))
    corners = little_endian(indices)
    records = bytearray(13 * faces)
    records[0::13] = b"\x03" * faces
    for byte in range(12):
        records[1 + byte::13] = corners[byte::12]
    out.write(records)


def write_binary_stl(out, positions, indices):
    faces = len(indices) // 3
    out.write(b"bench/mesh_convert.py".ljust(80, b" ") + struct.pack("<I", faces))
    corners = array.array("f", bytes(36 * faces))
    for k in range(3):
        for axis in range(3):
            corners[3 * k + axis::9] = array.array("f", (positions[3 * i + axis] for i in indices[k::3]))
    coordinates = little_endian(corners)
    records = bytearray(50 * faces)  # normal 0 (libvox takes it from the corners), attribute 0
    for byte in range(36):
        records[12 + byte::50] = coordinates[byte::36]
    out.write(records)


def write_text(out, kind, positions, indices, ascii_ply=False):
    vertices, faces = len(positions) // 3, len(indices) // 3
    if kind == "off":
        out.write(f"OFF\n{vertices} {faces} 0\n")
    elif ascii_ply:
        out.write(f"ply\nformat ascii 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n"
                  f"element face {faces}\nproperty list uchar int vertex_indices\nend_header\n")
    vertex = "v {:.9g} {:.9g} {:.9g}\n" if kind == "obj" else "{:.9g} {:.9g} {:.9g}\n"
    for v in range(vertices):
        out.write(vertex.format(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]))
    if kind == "obj":
        for f in range(faces):
            out.write(f"f {indices[3 * f] + 1} {indices[3 * f + 1] + 1} {indices[3 * f + 2] + 1}\n")
    else:
        for f in range(faces):
            out.write(f"3 {indices[3 * f]} {indices[3 * f + 1]} {indices[3 * f + 2]}\n")


def main():
    args = [a for a in sys.argv[1:] if a != "--ascii"]
    if len(args) != 2:
        sys.exit(__doc__)
    positions, indices = read_glb(args[0])
    kind = args[1].rsplit(".", 1)[-1].lower()
    if kind == "ply" and "--ascii" not in sys.argv:
        with open(args[1], "wb") as out:
            write_binary_ply(out, positions, indices)
    elif kind == "stl":
        with open(args[1], "wb") as out:
            write_binary_stl(out, positions, indices)
    elif kind in ("ply", "obj", "off"):
        with open(args[1], "w") as out:
            write_text(out, kind, positions, indices, ascii_ply=kind == "ply")
    else:
        sys.exit(f"mesh_convert.py: unknown output type '{kind}'")


if __name__ == "__main__":
    main()
