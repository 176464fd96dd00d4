// The one C++ file of gaussvid: a C interface to Debian's libsentencepiece (the umT5
// tokenizer's model, google/umt5-xxl/spiece.model), compiled only when CMake finds the
// library (umt5_tokenizer.c calls it under GV_HAVE_SENTENCEPIECE). No exception leaves it.
#include <cstdint>
#include <cstdio>
#include <new>
#include <string>
#include <vector>

#include <sentencepiece_processor.h>

extern "C" {

void *gv_spm_open(const char *path, char *error, size_t size)
{
    try {
        auto *sp = new sentencepiece::SentencePieceProcessor();
        auto status = sp->Load(path);
        if (!status.ok()) {
            std::snprintf(error, size, "%s", status.ToString().c_str());
            delete sp;
            return nullptr;
        }
        return sp;
    } catch (const std::exception &e) {
        std::snprintf(error, size, "%s", e.what());
        return nullptr;
    }
}

void gv_spm_close(void *handle)
{
    delete static_cast<sentencepiece::SentencePieceProcessor *>(handle);
}

int gv_spm_vocab(const void *handle)
{
    return static_cast<const sentencepiece::SentencePieceProcessor *>(handle)->GetPieceSize();
}

int gv_spm_eos(const void *handle)
{
    return static_cast<const sentencepiece::SentencePieceProcessor *>(handle)->eos_id();
}

// The ids of text, at most max of them (the count is returned even when larger); -1 on error.
long gv_spm_encode(const void *handle, const char *text, int32_t *ids, long max, char *error, size_t size)
{
    try {
        std::vector<int> out;
        auto status = static_cast<const sentencepiece::SentencePieceProcessor *>(handle)->Encode(text, &out);
        if (!status.ok()) {
            std::snprintf(error, size, "%s", status.ToString().c_str());
            return -1;
        }
        for (size_t i = 0; i < out.size() && (long)i < max; i++) ids[i] = out[i];
        return (long)out.size();
    } catch (const std::exception &e) {
        std::snprintf(error, size, "%s", e.what());
        return -1;
    }
}

}  // extern "C"
