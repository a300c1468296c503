// Above-threshold run segments of 32-pixel row chunks, with exact integer sums.
//
// One invocation per (row, chunk). A chunk without a pixel f ≥ T writes
// nothing; otherwise every maximal run of pixels f ≥ T inside the chunk is
// appended to `segments` with ΣF, ΣF·dx, ΣF·dx² (dx from the segment's first
// column; F = f − T, or F = f when `raw` is set). Over ≤ 32 pixels of ≤ 65535
// these fit in u32: ΣF·dx² ≤ 65535 · Σ_{dx<32} dx² = 682 612 560 < 2^32.
// No floating point anywhere.

struct Params {
    // Frame width (px).
    width: u32,
    // Rows in this band.
    rows: u32,
    // Frame row of the band's first row.
    first_row: u32,
    // Constant threshold T (DN), when `use_map` is 0.
    threshold: u32,
    // 1: per-pixel thresholds in `levels` (same layout as `pixels`).
    use_map: u32,
    // 1: F = f; 0: F = f − T.
    raw: u32,
    // Saturation level (DN): 255 or 65535.
    saturation: u32,
    // Chunks per row.
    chunks: u32,
}

// One run segment (24 bytes).
struct Segment {
    // Frame row.
    y: u32,
    // First column.
    x0: u32,
    // Bits 0..4: length − 1; 8..13: saturated pixels; 16..31: peak (DN).
    packed: u32,
    // ΣF.
    sum_f: u32,
    // ΣF·dx.
    sum_fdx: u32,
    // ΣF·dx².
    sum_fdx2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// The band's pixels, two u16 per word, little end first.
@group(0) @binding(1) var<storage, read> pixels: array<u32>;
// Per-pixel thresholds of the band (same layout), or a dummy.
@group(0) @binding(2) var<storage, read> levels: array<u32>;
// Segments found so far (may exceed the capacity: the host then retries).
@group(0) @binding(3) var<storage, read_write> count: atomic<u32>;
@group(0) @binding(4) var<storage, read_write> segments: array<Segment>;

const CHUNK: u32 = 32u;

// Pixel i of the band (row-major).
fn pixel(i: u32) -> u32 {
    return (pixels[i >> 1u] >> ((i & 1u) << 4u)) & 0xffffu;
}

// Threshold of pixel i of the band.
fn level(i: u32) -> u32 {
    if params.use_map != 0u {
        return (levels[i >> 1u] >> ((i & 1u) << 4u)) & 0xffffu;
    }
    return params.threshold;
}

fn emit(y: u32, x0: u32, x1: u32, sat: u32, peak: u32, sf: u32, sfdx: u32, sfdx2: u32) {
    let k = atomicAdd(&count, 1u);
    if k < arrayLength(&segments) {
        segments[k] = Segment(y, x0, (x1 - x0) | (sat << 8u) | (peak << 16u), sf, sfdx, sfdx2);
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let chunk = id.x;
    let row = id.y;
    if chunk >= params.chunks || row >= params.rows {
        return;
    }
    let x_begin = chunk * CHUNK;
    let x_end = min(x_begin + CHUNK, params.width);
    let base = row * params.width;

    // Most chunks hold no signal: one pass over the chunk's words to find out.
    let i0 = base + x_begin;
    let i1 = base + x_end;
    var any = false;
    if params.use_map == 0u {
        // Largest pixel of the chunk (halves outside [i0, i1) count as 0).
        var m = 0u;
        let words_end = (i1 + 1u) >> 1u;
        for (var j = i0 >> 1u; j < words_end; j++) {
            let w = pixels[j];
            let lo = select(w & 0xffffu, 0u, 2u * j < i0);
            let hi = select(w >> 16u, 0u, 2u * j + 1u >= i1);
            m = max(m, max(lo, hi));
        }
        any = m >= params.threshold;
    } else {
        for (var i = i0; i < i1; i++) {
            any = any || pixel(i) >= level(i);
        }
    }
    if !any {
        return;
    }

    let y = params.first_row + row;
    var open = false;
    var x0 = 0u;
    var sf = 0u;
    var sfdx = 0u;
    var sfdx2 = 0u;
    var peak = 0u;
    var sat = 0u;
    for (var x = x_begin; x < x_end; x++) {
        let i = base + x;
        let p = pixel(i);
        let t = level(i);
        if p >= t {
            if !open {
                open = true;
                x0 = x;
                sf = 0u;
                sfdx = 0u;
                sfdx2 = 0u;
                peak = 0u;
                sat = 0u;
            }
            let f = select(p - t, p, params.raw != 0u);
            let dx = x - x0;
            sf += f;
            sfdx += f * dx;
            sfdx2 += f * dx * dx;
            peak = max(peak, p);
            sat += select(0u, 1u, p >= params.saturation);
        } else if open {
            emit(y, x0, x - 1u, sat, peak, sf, sfdx, sfdx2);
            open = false;
        }
    }
    if open {
        emit(y, x0, x_end - 1u, sat, peak, sf, sfdx, sfdx2);
    }
}
