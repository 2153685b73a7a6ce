"""Writes the malformed-input corpus in this folder (committed; re-run to regenerate).

Standard library only: `python3 make_bad.py`. Text files are written here; binary ones are
derived from the valid files in `../formats/` (written by laspy, lazrs and pye57, see
`../formats/make_formats.py`) by truncating them, lying in a header field, or flipping bytes,
so every file is wrong in exactly one way. `expected.tsv` says, per file, the error the
readers must give; `tests/bad_input.rs` checks it and that every file here is listed.
"""

import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
FORMATS = os.path.join(HERE, "..", "formats")


def text(name, body):
    with open(os.path.join(HERE, name), "w", newline="\n") as f:
        f.write(body)


def binary(name, data):
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


def valid(name):
    with open(os.path.join(FORMATS, name), "rb") as f:
        return bytearray(f.read())


def crc32c(data):
    """CRC-32C (Castagnoli), the checksum of every E57 page."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


PLY_HEAD = "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
TRI = "0 0 0\n1 0 0\n0 1 0\n"

# ---- PLY
text("empty.ply", "")
text("ply_bad_magic.ply", "plx\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n")
text("ply_bad_format.ply", "ply\nformat json 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n")
text("ply_no_end_header.ply", PLY_HEAD.format(n=3))
text("ply_truncated.ply", PLY_HEAD.format(n=5) + "end_header\n" + TRI)
text("ply_not_a_number.ply", PLY_HEAD.format(n=3) + "end_header\n0 0 0\n1 abc 0\n0 1 0\n")
text("ply_nan.ply", PLY_HEAD.format(n=3) + "end_header\n0 0 0\n1 nan 0\n0 1 0\n")
text("ply_inf.ply", PLY_HEAD.format(n=3) + "end_header\n0 0 0\n1 0 0\n0 inf 0\n")
text("ply_no_z.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n0 0\n1 1\n")
text(
    "ply_face_missing_vertex.ply",
    PLY_HEAD.format(n=3)
    + "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    + TRI
    + "3 0 1 7\n",
)
text(
    "ply_huge_count.ply",
    PLY_HEAD.format(n=10**18) + "end_header\n" + TRI,
)
NORMALS_HEAD = "property float nx\nproperty float ny\nproperty float nz\nend_header\n"
text("ply_normal_zero.ply", PLY_HEAD.format(n=3) + NORMALS_HEAD + "0 0 0 0 0 1\n1 0 0 0 0 0\n0 1 0 0 0 1\n")
binary(
    "ply_normal_nan.ply",
    (PLY_HEAD.format(n=3).replace("ascii", "binary_little_endian") + NORMALS_HEAD).encode()
    + struct.pack("<18f", 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 1, 0, float("nan"), 0, 1),
)
head = PLY_HEAD.format(n=4).replace("ascii", "binary_little_endian") + "end_header\n"
binary("ply_binary_truncated.ply", head.encode() + struct.pack("<9f", *range(9)) + b"\x00\x00")

# ---- OFF
text("empty.off", "")
text("off_bad_magic.off", "OFX\n3 1 0\n" + TRI + "3 0 1 2\n")
text("off_truncated.off", "OFF\n5 0 0\n" + TRI)
text("off_not_a_number.off", "OFF\n3 0 0\n0 0 0\n1 0 x\n0 1 0\n")
text("off_nan.off", "OFF\n3 0 0\n0 0 0\nNaN 0 0\n0 1 0\n")
text("off_face_missing_vertex.off", "OFF\n3 1 0\n" + TRI + "3 0 1 3\n")
text("off_face_two_corners.off", "OFF\n3 1 0\n" + TRI + "2 0 1\n")
text("off_huge_count.off", "OFF\n1000000000000000000 0 0\n" + TRI)
text("off_counts_missing.off", "OFF\n3\n" + TRI)
text("off_short_vertex.off", "OFF\n3 0 0\n0 0 0\n1 0\n0 1 0\n")

# ---- OBJ
text("empty.obj", "")
text("obj_not_a_number.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\n")
text("obj_nan.obj", "v 0 0 0\nv 1 0 0\nv 0 1 nan\n")
text("obj_short_vertex.obj", "v 0 0 0\nv 1 0\nv 0 1 0\n")
text("obj_face_missing_vertex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
text("obj_face_zero_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
text("obj_face_two_corners.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n")

# ---- XYZ
text("empty.xyz", "")
text("xyz_not_a_number.xyz", "0 0 0\n1 0 0\n0 one 0\n")
text("xyz_nan.xyz", "0 0 0\nnan 0 0\n")
text("xyz_inf.xyz", "0 0 0\n1 -inf 0\n")
text("xyz_short_line.xyz", "0 0 0\n1 0\n")
text("xyz_comments_only.xyz", "# no points\n\n")
text("xyz_normal_long.xyz", "# x y z nx ny nz\n0 0 0 0 0 1\n1 0 0 0 0 2\n")
text("xyz_six_columns_neither.xyz", "0 0 0 200 100 50\n1 0 0 0.5 0.5 0.5\n")
text("xyz_six_columns_both.xyz", "0 0 0 0 0 1\n1 0 0 1 0 0\n")

# ---- PCD
PCD_HEAD = (
    "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
    "WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
)
text("empty.pcd", "")
text("pcd_wrong_size.pcd", PCD_HEAD.format(n=3, data="ascii").replace("SIZE 4 4 4", "SIZE 4 4") + TRI)
text("pcd_truncated_ascii.pcd", PCD_HEAD.format(n=5, data="ascii") + TRI)
text("pcd_not_a_number.pcd", PCD_HEAD.format(n=3, data="ascii") + "0 0 0\n1 0 0\n0 q 0\n")
text("pcd_bad_type.pcd", PCD_HEAD.format(n=3, data="ascii").replace("TYPE F F F", "TYPE F F Z") + TRI)
text("pcd_huge_points.pcd", PCD_HEAD.format(n=10**15, data="binary"))
binary(
    "pcd_truncated_binary.pcd",
    PCD_HEAD.format(n=4, data="binary").encode() + struct.pack("<9f", *range(9)) + b"\x00",
)
text("pcd_unknown_data.pcd", PCD_HEAD.format(n=3, data="zipped") + TRI)
text(
    "pcd_normal_nan.pcd",
    PCD_HEAD.format(n=3, data="ascii")
    .replace("FIELDS x y z", "FIELDS x y z normal_x normal_y normal_z")
    .replace("SIZE 4 4 4", "SIZE 4 4 4 4 4 4")
    .replace("TYPE F F F", "TYPE F F F F F F")
    .replace("COUNT 1 1 1", "COUNT 1 1 1 1 1 1")
    + "0 0 0 0 0 1\n1 0 0 nan nan nan\n0 1 0 0 0 1\n",
)

# ---- LAS / LAZ (from laspy's tiny.las and lazrs's tiny.laz: LAS 1.4, point format 3, 5 points)
binary("empty.las", b"")
las = valid("tiny.las")
lying = bytearray(las)
struct.pack_into("<Q", lying, 247, 1000)  # LAS 1.4 point count: 1000 announced, 5 present
binary("las_lying_count.las", lying)
binary("las_truncated.las", las[: 375 + 34 * 2 + 10])  # header + 2.3 points
sig = bytearray(las)
sig[0:4] = b"LASX"
binary("las_bad_signature.las", sig)
binary("las_truncated_header.las", las[:100])
laz = valid("tiny.laz")
corrupt = bytearray(laz)
for k in range(500, 560):  # inside the one compressed chunk (data 489..586)
    corrupt[k] ^= 0xA5
binary("laz_corrupt_chunk.laz", corrupt)
binary("laz_truncated.laz", laz[:520])
# Found by tests/fuzz_readers.rs: one byte deleted inside the compressed data moves the chunk
# table, whose count then reads as a billion chunks (`laz` reserved 16 GB for it).
binary("laz_chunk_count.laz", laz[:546] + laz[547:])
no_items = bytearray(laz)
struct.pack_into("<H", no_items, 375 + 54 + 32, 0)  # the LASzip VLR's item count (`laz` panicked)
binary("laz_no_items.laz", no_items)
# Found by the fuzzing too: a record length and a 64-bit count whose product overflows (the
# `las` crate's offset_to_end_of_points panicked in debug builds).
overflow = bytearray(las)
struct.pack_into("<H", overflow, 105, 1024)
struct.pack_into("<Q", overflow, 247, 1 << 60)
binary("las_count_overflow.las", overflow)
# Corruption read as data. A point outside the header's box (its X moved by 100,000
# units of the 0.001 scale), the same point inside a LAZ whose box was shrunk, an x scale of 0,
# a count below the records the file holds, and LAS 1.4's two counts disagreeing.
outside = bytearray(las)
struct.pack_into("<i", outside, 375 + 2 * 34, 100_000_000)
binary("las_outside_box.las", outside)
small_box = bytearray(laz)
struct.pack_into("<d", small_box, 179, 500001.0)  # max x below the points' 500002.375
binary("laz_outside_box.laz", small_box)
scale0 = bytearray(las)
struct.pack_into("<d", scale0, 131, 0.0)
binary("las_scale_zero.las", scale0)
too_few = bytearray(las)
struct.pack_into("<Q", too_few, 247, 3)  # 3 announced, 5 records present
binary("las_count_too_low.las", too_few)
disagree = bytearray(las)
struct.pack_into("<I", disagree, 107, 3)  # legacy 3, 64-bit 5
binary("las_count_mismatch.las", disagree)

# A normal of NaN in laspy's normals_pdal.las (point format 0 and 12 extra bytes, f32
# NormalX, NormalY, NormalZ): point 2's NormalX.
normals = valid("normals_pdal.las")
start = struct.unpack_from("<I", normals, 96)[0]
record = struct.unpack_from("<H", normals, 105)[0]
struct.pack_into("<f", normals, start + 2 * record + 20, float("nan"))
binary("las_normal_nan.las", normals)

# ---- E57 (from pye57's tiny.e57: 1024-byte pages, each ending in the CRC-32C of its 1020)
e57 = valid("tiny.e57")
binary("empty.e57", b"")
binary("e57_truncated.e57", e57[:3000])
bad_crc = bytearray(e57)
bad_crc[400] ^= 0x01
binary("e57_bad_checksum.e57", bad_crc)
broken = bytearray(e57)
at = broken.find(b"<formatName")
broken[at : at + len(b"<formatName")] = b"<formatNam<"  # an unclosed tag, same length
page = broken[0:1020]
stored = bytes(e57[1020:1024])
crc = crc32c(bytes(e57[0:1020]))
order = ">" if stored == struct.pack(">I", crc) else "<"
assert stored == struct.pack(order + "I", crc), "the E57 page checksum layout is as assumed"
struct.pack_into(order + "I", broken, 1020, crc32c(bytes(page)))
binary("e57_broken_xml.e57", broken)

# ---- Views files (JSON lines of cameras)
GOOD = '{"model":"pinhole","width":64,"height":48,"eye":[0,0,5],"target":[0,0,0],"up":[0,1,0],"fov_y_deg":40}'
text("views_not_json.jsonl", GOOD + "\n{model: pinhole}\n")
text("views_unknown_model.jsonl", GOOD.replace('"pinhole"', '"fisheye"') + "\n")
text("views_nan_eye.jsonl", GOOD + "\n" + GOOD.replace("[0,0,5]", '[0,"NaN",5]') + "\n")
text("views_eye_on_target.jsonl", GOOD.replace('"target":[0,0,0]', '"target":[0,0,5]') + "\n")
text("views_up_along_view.jsonl", GOOD.replace('"up":[0,1,0]', '"up":[0,0,1]') + "\n")
text("views_zero_width.jsonl", GOOD.replace('"width":64', '"width":0') + "\n")
text("views_width_overflow.jsonl", GOOD.replace('"width":64', '"width":4294967296') + "\n")
text("views_negative_fov.jsonl", GOOD.replace('"fov_y_deg":40', '"fov_y_deg":-40') + "\n")
text("views_fov_180.jsonl", GOOD.replace('"fov_y_deg":40', '"fov_y_deg":180') + "\n")
text(
    "views_not_rotation.jsonl",
    '{"model":"pinhole","width":64,"height":48,'
    '"camera_to_world":[[2,0,0,0],[0,2,0,0],[0,0,2,5],[0,0,0,1]],"fx":50,"fy":50,"cx":32,"cy":24}\n',
)
text(
    "views_nan_pose.jsonl",
    '{"model":"pinhole","width":64,"height":48,'
    '"camera_to_world":[[1,0,0,0],[0,-1,0,0],[0,0,-1,"NaN"],[0,0,0,1]],"fx":50,"fy":50,"cx":32,"cy":24}\n',
)
text(
    "views_negative_focal.jsonl",
    '{"model":"pinhole","width":64,"height":48,'
    '"camera_to_world":[[1,0,0,0],[0,-1,0,0],[0,0,-1,5],[0,0,0,1]],"fx":-50,"fy":50,"cx":32,"cy":24}\n',
)
text("views_empty.jsonl", "# no cameras\n")
