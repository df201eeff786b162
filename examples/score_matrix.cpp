// score_matrix.cpp - libphks from C++: the signatures of every mesh file on
// the command line, then the matrix of their scores (lower is more alike).
//
//   score-matrix a.off b.off c.ply
//
// phks.h is plain C with extern "C", so C++ includes it as is. Here every
// handle lives in a std::unique_ptr whose deleter is the matching *_free
// function, and a failed call throws, carrying phks_last_error_message().
//
// Build against an installed libphks (C++11 or later):
//   c++ score_matrix.cpp $(pkg-config --cflags --libs phks) -o score-matrix
#include <phks.h>

#include <cstddef>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// Owning handles: freed when they go out of scope, on every path.
struct MeshDeleter {
    void operator()(phks_mesh *m) const { phks_mesh_free(m); }
};
struct SignatureDeleter {
    void operator()(phks_signature *s) const { phks_signature_free(s); }
};
using Mesh = std::unique_ptr<phks_mesh, MeshDeleter>;
using Signature = std::unique_ptr<phks_signature, SignatureDeleter>;

// Throws when a call failed. The message is read at once: it is only valid
// until the next failing call in this thread.
void check(phks_status status, const std::string &what)
{
    if (status != PHKS_OK)
        throw std::runtime_error(what + ": " + phks_status_string(status) +
                                 " (" + phks_last_error_message() + ")");
}

Signature signature_of(const std::string &path, const phks_options &options)
{
    phks_mesh *raw_mesh = nullptr;
    check(phks_mesh_load(path.c_str(), &raw_mesh), path);
    Mesh mesh(raw_mesh);

    phks_signature *raw_sig = nullptr;
    check(phks_signature_compute(mesh.get(), &options, &raw_sig), path);
    return Signature(raw_sig);
}

} // namespace

int main(int argc, char **argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: score-matrix MESH...\n");
        return 2;
    }
    try {
        // One set of options for all: only signatures made with the same
        // options can be compared (phks_score refuses others).
        phks_options options;
        check(phks_options_init(&options), "options");

        std::vector<std::string> paths(argv + 1, argv + argc);
        std::vector<Signature> sigs;
        for (const std::string &path : paths) {
            sigs.push_back(signature_of(path, options));
            std::printf("%zu: %s, %zu features\n", sigs.size() - 1,
                        path.c_str(),
                        phks_signature_feature_count(sigs.back().get()));
        }

        std::printf("\nscores:\n");
        for (std::size_t i = 0; i < sigs.size(); i++) {
            std::printf("%3zu:", i);
            for (std::size_t j = 0; j < sigs.size(); j++) {
                double score = 0;
                check(phks_score(sigs[i].get(), sigs[j].get(), &score),
                      "score");
                std::printf(" %9.4g", score);
            }
            std::printf("\n");
        }
    } catch (const std::exception &e) {
        std::fprintf(stderr, "score-matrix: %s\n", e.what());
        return 1;
    }
    return 0;
}
