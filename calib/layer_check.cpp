// The program of each layer's link check (calib/CMakeLists.txt): linked with
// every object of one layer and the layers below it, never run. It links only
// if the layer calls nothing of a layer above it.
int main() { return 0; }
