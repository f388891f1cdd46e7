// Marks every float arithmetic result of a SPIR-V module NoContraction: Rust never fuses or reassociates float
// operations, and without the decoration drivers may (Mesa's NIR rewrites a*b + a*c to a*(b + c), GPUs fuse
// multiply-adds), which would break the bit-for-bit twinning of psdr's CPU reference. Shared (by `include!`) by
// psdr's build script, which decorates the build-time SPIR-V, and psdr-vk's run-time shader compiler.
// (Plain comments, not //!: this file is also included into a build script.)

/// `words` with `OpDecorate %result NoContraction` added for the result of every float arithmetic instruction,
/// or why the module cannot be decorated.
pub fn decorate_no_contraction(words: &[u32]) -> Result<Vec<u32>, String> {
    const OP_DECORATE: u32 = 71;
    const OP_MEMBER_DECORATE: u32 = 72;
    const NO_CONTRACTION: u32 = 42;
    // OpFNegate, OpFAdd, OpFSub, OpFMul, OpFDiv, OpFRem, OpFMod, OpVectorTimesScalar, OpMatrixTimesScalar,
    // OpVectorTimesMatrix, OpMatrixTimesVector, OpMatrixTimesMatrix, OpOuterProduct, OpDot: [op, type, result, ..].
    const ARITHMETIC: [u32; 14] = [127, 129, 131, 133, 136, 140, 141, 142, 143, 144, 145, 146, 147, 148];
    if words.len() < 5 {
        return Err("shorter than the SPIR-V header".into());
    }
    let (mut decorations, mut annotations_at) = (Vec::new(), None);
    let mut i = 5; // after the header
    while i < words.len() {
        let (count, op) = ((words[i] >> 16) as usize, words[i] & 0xffff);
        if count == 0 || i + count > words.len() {
            return Err(format!("malformed instruction at word {i}"));
        }
        if (op == OP_DECORATE || op == OP_MEMBER_DECORATE) && annotations_at.is_none() {
            annotations_at = Some(i);
        }
        if ARITHMETIC.contains(&op) {
            decorations.extend([(3 << 16) | OP_DECORATE, words[i + 2], NO_CONTRACTION]);
        }
        i += count;
    }
    // Decorations belong in the annotation section; every kernel has one (its buffer bindings).
    let at = annotations_at.ok_or("no annotation section")?;
    Ok(words[..at].iter().chain(&decorations).chain(&words[at..]).copied().collect())
}
