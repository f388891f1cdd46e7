//! Connected regions of a label image: the 4-connected runs of pixels that share a label (segmentation
//! classes into instances, light-source pixels into lights).

/// The 4-connected regions of pixels with equal labels in a `width`-wide label image, each as its pixel
/// indices (its first pixel first), in order of their first pixel.
pub fn connected_regions<T: PartialEq>(labels: &[T], width: usize) -> Vec<Vec<usize>> {
    let (w, n) = (width.max(1), labels.len());
    let mut seen = vec![false; n];
    let mut stack = vec![];
    let mut regions = vec![];
    for start in 0..n {
        if seen[start] {
            continue;
        }
        let mut region = vec![];
        seen[start] = true;
        stack.push(start);
        while let Some(p) = stack.pop() {
            region.push(p);
            let (x, y) = (p % w, p / w);
            let mut visit = |q: usize| {
                if !seen[q] && labels[q] == labels[p] {
                    seen[q] = true;
                    stack.push(q);
                }
            };
            if x > 0 {
                visit(p - 1);
            }
            if x + 1 < w {
                visit(p + 1);
            }
            if y > 0 {
                visit(p - w);
            }
            if p + w < n {
                visit(p + w);
            }
        }
        regions.push(region);
    }
    regions
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two 1s that touch only at a corner are two regions; the 0s around them one (4-connectivity).
    #[test]
    fn regions_are_four_connected() {
        let labels = [1, 0, 0, 0, 1, 0, 0, 0, 0];
        let r = connected_regions(&labels, 3);
        assert_eq!(r.len(), 3, "{r:?}");
        assert_eq!(r[0], vec![0]);
        let mut zeros = r[1].clone();
        zeros.sort();
        assert_eq!(zeros, vec![1, 2, 3, 5, 6, 7, 8]);
        assert_eq!(r[2], vec![4]);
    }
}
