#!/usr/bin/env python3
"""Writes the binary image files of the bad-input corpus (run from this folder).

Each is a few hundred bytes at most: a header that claims what the case needs
and as little data as will do. Standard library only.
"""
import struct
import zlib

# TIFF tags.
WIDTH, HEIGHT, BITS, COMPRESSION, PHOTOMETRIC = 256, 257, 258, 259, 262
STRIP_OFFSETS, SAMPLES, ROWS_PER_STRIP, STRIP_BYTES = 273, 277, 278, 279
SHORT, LONG = 3, 4


def tiff(width, height, data, bits=16, compression=1, samples=1):
    """Little-endian baseline TIFF, one strip holding `data`."""
    entries = sorted([
        (WIDTH, LONG, width), (HEIGHT, LONG, height), (BITS, SHORT, bits),
        (COMPRESSION, SHORT, compression), (PHOTOMETRIC, SHORT, 1),
        (STRIP_OFFSETS, LONG, 0), (SAMPLES, SHORT, samples),
        (ROWS_PER_STRIP, LONG, height), (STRIP_BYTES, LONG, len(data)),
    ])
    data_offset = 8 + 2 + 12 * len(entries) + 4
    out = b"II*\0" + struct.pack("<IH", 8, len(entries))
    for tag, kind, value in entries:
        if tag == STRIP_OFFSETS:
            value = data_offset
        if kind == SHORT:
            out += struct.pack("<HHIHH", tag, kind, 1, value, 0)
        else:
            out += struct.pack("<HHII", tag, kind, 1, value)
    return out + struct.pack("<I", 0) + data


def png(width, height, rows, depth=16, colour=0):
    """PNG with one IDAT of the given filtered rows (bytes)."""
    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    header = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def u16(values):
    return struct.pack("<%dH" % len(values), *values)


def frame8(width, height, background, square, level):
    """8-bit frame: `background` everywhere, a `square` (x0, y0, size) at `level`."""
    x0, y0, n = square
    return bytes(level if x0 <= x < x0 + n and y0 <= y < y0 + n else background
                 for y in range(height) for x in range(width))


def write(path, data):
    with open(path, "wb") as f:
        f.write(data)


def main():
    ok = tiff(2, 2, u16([100, 200, 300, 400]))
    for case in ["extract_tiff_header_huge", "extract_tiff_header_1e6x1e5",
                 "extract_tiff_header_over_max_pixels", "extract_png_header_huge",
                 "extract_png_header_1e6x1e5", "extract_max_pixels_lowered",
                 "extract_truncated_tiff", "extract_empty_file", "extract_not_an_image",
                 "extract_colour_png"]:
        write(f"{case}/ok.tif", ok)
    write("_shared/ok.tif", ok)
    # A dark frame given by mistake: a flat level, no blob.
    write("extract_no_blob/dark.tif", tiff(8, 8, u16([100] * 64)))
    # Headers that claim more than any sensor (4 bytes of data).
    write("extract_tiff_header_huge/huge.tif", tiff(4294967295, 4294967295, u16([0, 0])))
    write("extract_tiff_header_1e6x1e5/big.tif", tiff(1000000, 100000, u16([0, 0])))
    write("extract_tiff_header_over_max_pixels/big.tif", tiff(20000, 20000, u16([0, 0])))
    write("extract_png_header_huge/huge.png", png(2147483647, 2147483647, b"\0" * 8))
    write("extract_png_header_1e6x1e5/big.png", png(1000000, 100000, b"\0" * 8))
    # A 20×20 frame whose strip stops after 100 of its 800 bytes (the header
    # and its 9 tags take 122 bytes).
    write("extract_truncated_tiff/cut.tif", tiff(20, 20, u16([1000] * 400))[:122 + 100])
    write("extract_truncated_png/cut.png", png(16, 16, b"".join(
        b"\0" + b"\x10\x00" * 16 for _ in range(16)))[:60])
    write("extract_empty_file/empty.tif", b"")
    write("extract_colour_png/rgb.png", png(2, 2, b"\0" + b"\x80" * 6 + b"\0" + b"\x80" * 6,
                                            depth=8, colour=2))
    # A whole saturated frame 65536 px wide (the widest accepted): one run
    # per row of Σ 65535·dx² ≈ 6e18, still exact; every pixel at T.
    row = b"\0" + b"\xff\xff" * 65536  # filter byte "none", then the row
    write("extract_saturated_full_width/white.png", png(65536, 2, row * 2))
    write("extract_saturated_full_width_raw/white.png", png(65536, 2, row * 2))
    # 8-bit frames with a saturated 4×4 square on a background of 10 DN.
    square = frame8(16, 16, 10, (6, 6, 4), 255)
    write("extract_saturated_blob_weightless/sat8.tif", tiff(16, 16, square, bits=8))
    write("extract_saturated_blob_kept/sat8.tif", tiff(16, 16, square, bits=8))


if __name__ == "__main__":
    main()
