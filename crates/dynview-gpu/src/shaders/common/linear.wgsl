// The element index of a linear kernel (`@workgroup_size(64)`): a long dispatch is folded into
// rows of `groups.x` workgroups so that no dimension passes the device's limit (65,535 by
// default: 4.2 million elements in one row); `Kernel::dispatch` folds it.
fn linear_index(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.y * groups.x * 64u + id.x;
}
