// The item a compute invocation works on, over a 2D grid of work groups (gpu/deform.py's
// `dispatch` lays it out): GL 4.3 promises 65535 groups an axis at least, fewer than a large
// mesh's vertices over a group's size.
int dispatch_index() {
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    return int(group * gl_WorkGroupSize.x + gl_LocalInvocationID.x);
}
