typedef int shapes_placeholder_;
