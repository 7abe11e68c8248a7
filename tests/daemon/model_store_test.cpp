// The model store against real files: a real mesh uploaded in uneven chunks, every refusal with the
// code and data a client acts on, an upload resumed by a new store on the same folder, and the
// "file:" references that must not leave models_dir.
#include "daemon/model_store.hpp"

#include <filesystem>
#include <fstream>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "daemon/client/base64.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/client/sha256.hpp"
#include "fresh_folder.hpp"

namespace cmm::daemon {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string read_all(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

const fs::path sample = fs::path(CMMD_SOURCE_DIR) / "config/samples/case3_block.ply";

struct Upload {
  std::string bytes = read_all(sample);
  std::string sha = sha256_hex_of_file(sample);
  std::string name = "Case3_Block.PLY";

  UploadChunk chunk(std::uint64_t offset, std::uint64_t length) const {
    return {name, bytes.size(), sha, offset, encode_base64(std::string_view(bytes).substr(offset, length))};
  }
};

// Runs `call`, which must throw RpcError `code`; returns it for a closer look.
template <typename Call>
RpcError rpc_error_of(Call call, int code) {
  try {
    call();
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    return e;
  }
  ADD_FAILURE() << "no RpcError";
  return RpcError(0, "none");
}

std::size_t files_in(const fs::path& dir) {
  return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

TEST(Base64, RoundTripsEveryLengthAndRefusesWhatIsNotBase64) {
  std::string bytes;
  for (int i = 0; i < 300; ++i) {
    EXPECT_EQ(decode_base64(encode_base64(bytes)), bytes) << "length " << i;
    bytes += static_cast<char>(i * 37);
  }
  EXPECT_EQ(encode_base64("cmm"), "Y21t");
  EXPECT_EQ(decode_base64("Y20="), "cm");
  EXPECT_EQ(decode_base64("Yw=="), "c");
  for (const char* bad : {"Y21", "Y2 t", "Y21t\n", "Y=0t", "Y21-", "Yw=a", "===="}) {
    EXPECT_THROW(decode_base64(bad), std::invalid_argument) << bad;
  }
  try {
    decode_base64("Y21tY2*t");
    FAIL() << "'*' was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("'*' at position 6"));
  }
}

TEST(Sha256, MatchesTheFipsDigests) {
  Sha256 empty;
  EXPECT_EQ(empty.hex_digest(), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  Sha256 abc;
  abc.update("a");
  abc.update("bc");
  EXPECT_EQ(abc.hex_digest(), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(ModelStore, UploadsARealMeshInUnevenChunks) {
  const fs::path dir = fresh_folder("models-chunks");
  ModelStore store(dir / "models", "");
  const Upload up;
  const std::uint64_t lengths[] = {1, 4095, 100000, 3, 250001};
  std::uint64_t offset = 0;
  for (const auto length : lengths) {
    const UploadStatus status = store.upload(up.chunk(offset, length));
    offset += length;
    EXPECT_EQ(status.received, offset);
    EXPECT_FALSE(status.complete);
    EXPECT_EQ(status.model, "sha256:" + up.sha + ".ply");
  }
  const UploadStatus last = store.upload(up.chunk(offset, up.bytes.size() - offset));
  EXPECT_TRUE(last.complete);
  EXPECT_EQ(last.received, up.bytes.size());
  const fs::path stored = dir / "models" / (up.sha + ".ply");  // the extension lowercased
  EXPECT_EQ(read_all(stored), up.bytes);
  EXPECT_EQ(store.resolve("sha256:" + up.sha), stored);
  EXPECT_EQ(store.resolve(last.model), stored);
  EXPECT_EQ(files_in(dir / "models" / ".partial"), 0u);
}

// The same bytes uploaded again under another format's name are that format from then on for that
// name; once kept under the first extension they stayed so (issue 13: "keep the first upload's
// extension"), and a misnamed upload could not be corrected.
TEST(ModelStore, TheSameBytesUnderAnotherExtensionAreKeptInThatFormatToo) {
  const fs::path dir = fresh_folder("models-extension");
  ModelStore store(dir / "models", "");
  Upload up;
  up.name = "part.stl";  // PLY bytes, misnamed
  const UploadStatus wrong = store.upload(up.chunk(0, up.bytes.size()));
  EXPECT_EQ(wrong.model, "sha256:" + up.sha + ".stl");
  EXPECT_EQ(store.resolve("sha256:" + up.sha), dir / "models" / (up.sha + ".stl"));
  up.name = "part.ply";
  const UploadStatus right = store.upload(up.chunk(0, 0));  // already stored: no bytes needed
  EXPECT_TRUE(right.complete);
  EXPECT_EQ(right.model, "sha256:" + up.sha + ".ply");
  EXPECT_EQ(store.resolve(right.model), dir / "models" / (up.sha + ".ply"));
  EXPECT_EQ(read_all(store.resolve(right.model)), up.bytes);
  EXPECT_EQ(store.resolve(wrong.model), dir / "models" / (up.sha + ".stl"));
  // Without the extension the reference is ambiguous now: refused, naming both.
  const RpcError e = rpc_error_of([&] { store.resolve("sha256:" + up.sha); }, rpc_code::invalid_params);
  EXPECT_EQ(e.data().at("path"), "/model");
  EXPECT_THAT(e.what(), HasSubstr(right.model));
  EXPECT_THAT(e.what(), HasSubstr(wrong.model));
  rpc_error_of([&] { store.resolve("sha256:" + up.sha + ".obj"); }, rpc_code::not_found);
  rpc_error_of([&] { store.resolve("sha256:" + up.sha + ".exe"); }, rpc_code::invalid_params);
}

TEST(ModelStore, AWrongSha256IsRefusedAndNothingIsStored) {
  const fs::path dir = fresh_folder("models-wrong-sha");
  ModelStore store(dir / "models", "");
  Upload up;
  up.sha = std::string(64, 'a');
  store.upload(up.chunk(0, 1000));
  const RpcError e = rpc_error_of([&] { store.upload(up.chunk(1000, up.bytes.size() - 1000)); }, rpc_code::upload_error);
  EXPECT_THAT(e.what(), HasSubstr("sha256 mismatch"));
  EXPECT_EQ(e.data().at("expected_offset"), 0);
  EXPECT_EQ(files_in(dir / "models"), 1u);  // .partial only
  EXPECT_EQ(files_in(dir / "models" / ".partial"), 0u);
  rpc_error_of([&] { store.resolve("sha256:" + up.sha); }, rpc_code::not_found);
}

TEST(ModelStore, AChunkOutOfOrderGetsTheExpectedOffset) {
  const fs::path dir = fresh_folder("models-order");
  ModelStore store(dir / "models", "");
  const Upload up;
  store.upload(up.chunk(0, 5000));
  RpcError e = rpc_error_of([&] { store.upload(up.chunk(6000, 10)); }, rpc_code::upload_error);
  EXPECT_EQ(e.data().at("expected_offset"), 5000);
  e = rpc_error_of([&] { store.upload(up.chunk(4000, 10)); }, rpc_code::upload_error);  // a repeat
  EXPECT_EQ(e.data().at("expected_offset"), 5000);
  // Nothing was lost by the refusals: the upload goes on where it was.
  EXPECT_EQ(store.upload(up.chunk(5000, 10)).received, 5010u);
  // A first chunk starts over.
  EXPECT_EQ(store.upload(up.chunk(0, 7)).received, 7u);
  e = rpc_error_of([&] { store.upload(up.chunk(5010, 10)); }, rpc_code::upload_error);
  EXPECT_EQ(e.data().at("expected_offset"), 7);
}

TEST(ModelStore, AnUploadGoesOnAfterARestart) {
  const fs::path dir = fresh_folder("models-resume");
  const Upload up;
  {
    ModelStore store(dir / "models", "");
    store.upload(up.chunk(0, 200000));
  }
  ModelStore store(dir / "models", "");
  const RpcError e = rpc_error_of([&] { store.upload(up.chunk(300000, 10)); }, rpc_code::upload_error);
  EXPECT_EQ(e.data().at("expected_offset"), 200000);
  const UploadStatus status = store.upload(up.chunk(200000, up.bytes.size() - 200000));
  EXPECT_TRUE(status.complete);
  EXPECT_EQ(read_all(store.resolve(status.model)), up.bytes);
}

TEST(ModelStore, AModelAlreadyStoredCompletesAtOnce) {
  const fs::path dir = fresh_folder("models-duplicate");
  ModelStore store(dir / "models", "");
  const Upload up;
  ASSERT_TRUE(store.upload(up.chunk(0, up.bytes.size())).complete);
  UploadChunk empty = up.chunk(0, 0);
  const UploadStatus again = store.upload(empty);
  EXPECT_TRUE(again.complete);
  EXPECT_EQ(again.received, up.bytes.size());
  EXPECT_EQ(files_in(dir / "models"), 2u);  // the model and .partial
}

TEST(ModelStore, RefusesBadBase64BadNamesBadDigestsAndOversizedModels) {
  const fs::path dir = fresh_folder("models-refusals");
  const Upload up;
  ModelStore store(dir / "models", "", 100000);
  UploadChunk chunk = up.chunk(0, 10);
  chunk.size = 1000;
  chunk.data_base64 = "Y21t!!!!";
  RpcError e = rpc_error_of([&] { store.upload(chunk); }, rpc_code::invalid_params);
  EXPECT_EQ(e.data().at("path"), "/data");
  EXPECT_THAT(e.what(), HasSubstr("base64"));

  chunk = up.chunk(0, 10);
  chunk.name = "part.step";
  e = rpc_error_of([&] { store.upload(chunk); }, rpc_code::invalid_params);
  EXPECT_EQ(e.data().at("path"), "/name");
  EXPECT_THAT(e.what(), HasSubstr("part.step"));
  chunk.name = "ply";  // no extension at all
  rpc_error_of([&] { store.upload(chunk); }, rpc_code::invalid_params);

  chunk = up.chunk(0, 10);
  chunk.sha256_hex = "abc";
  e = rpc_error_of([&] { store.upload(chunk); }, rpc_code::invalid_params);
  EXPECT_EQ(e.data().at("path"), "/sha256");

  e = rpc_error_of([&] { store.upload(up.chunk(0, 10)); }, rpc_code::upload_error);  // 499587 > 100000
  EXPECT_THAT(e.what(), HasSubstr("limit"));

  chunk = up.chunk(0, 10);
  chunk.size = 5;  // more bytes than declared
  rpc_error_of([&] { store.upload(chunk); }, rpc_code::upload_error);
  EXPECT_EQ(files_in(dir / "models"), 1u);
  EXPECT_EQ(files_in(dir / "models" / ".partial"), 0u);
}

// Raw scans are models too: every cloud format read_model knows is taken and named by its extension.
TEST(ModelStore, TakesPointCloudFormats) {
  const fs::path dir = fresh_folder("models-clouds");
  ModelStore store(dir / "models", "");
  const std::string bytes = "1 2 3\n4 5 6\n7 8 10\n";
  const std::string sha = sha256_hex_of_file([&] {
    std::ofstream(dir / "scan.xyz", std::ios::binary) << bytes;
    return dir / "scan.xyz";
  }());
  for (const std::string ext : {".xyz", ".asc", ".pcd", ".ply"}) {
    const UploadStatus st = store.upload({"scan" + ext, bytes.size(), sha, 0, encode_base64(bytes)});
    EXPECT_TRUE(st.complete);
    EXPECT_EQ(st.model, "sha256:" + sha + ext);
    EXPECT_EQ(store.resolve(st.model), dir / "models" / (sha + ext));
  }
  const RpcError e = rpc_error_of([&] { store.upload({"scan.las", bytes.size(), sha, 0, encode_base64(bytes)}); },
                                  rpc_code::invalid_params);
  EXPECT_THAT(e.what(), HasSubstr("\"scan.las\" is not a model file (expected a mesh or a point cloud: .stl, .ply, .obj, "
                                  ".off, .xyz, .asc or .pcd)"));
  EXPECT_THAT(rpc_error_of([&] { store.resolve("sha256:" + sha + ".las"); }, rpc_code::invalid_params).what(),
              HasSubstr("after the digest only .stl, .ply, .obj, .off, .xyz, .asc or .pcd may follow"));
}

TEST(ModelStore, TheDefaultLimitIsOneGibibyte) {
  EXPECT_EQ(ModelStore::default_max_model_bytes, std::uint64_t{1} << 30);
  const fs::path dir = fresh_folder("models-limit");
  ModelStore store(dir / "models", "");
  const RpcError e = rpc_error_of(
      [&] { store.upload({"scan.pcd", (std::uint64_t{1} << 30) + 1, std::string(64, 'a'), 0, ""}); }, rpc_code::upload_error);
  EXPECT_THAT(e.what(), HasSubstr("model of 1073741825 bytes is over the limit of 1073741824 bytes (1024 MiB)"));
}

TEST(ModelStore, ResolvesFilesInsideModelsDirOnly) {
  const fs::path dir = fresh_folder("models-resolve");
  const fs::path models = dir / "library";
  fs::create_directories(models / "blocks");
  std::ofstream(models / "blocks" / "a.stl") << "solid a\nendsolid a\n";
  std::ofstream(dir / "secret.stl") << "outside\n";
  fs::create_symlink(dir / "secret.stl", models / "escape.stl");
  fs::create_symlink(models / "blocks" / "a.stl", models / "alias.stl");
  ModelStore store(dir / "models", models);

  EXPECT_EQ(store.resolve("file:blocks/a.stl"), fs::canonical(models / "blocks" / "a.stl"));
  EXPECT_EQ(store.resolve("file:alias.stl"), fs::canonical(models / "blocks" / "a.stl"));  // a link that stays inside
  const std::vector<std::string> refused = {"file:../secret.stl", "file:blocks/../../secret.stl",
                                           "file:" + (dir / "secret.stl").string(), "file:escape.stl", "file:",
                                           "model.stl", "sha256:xyz"};
  for (const std::string& ref : refused) {
    const RpcError e = rpc_error_of([&] { store.resolve(ref); }, rpc_code::invalid_params);
    EXPECT_EQ(e.data().at("path"), "/model") << ref;
  }
  rpc_error_of([&] { store.resolve("file:blocks/missing.stl"); }, rpc_code::not_found);
  rpc_error_of([&] { store.resolve("file:blocks"); }, rpc_code::not_found);  // a folder is no model
  rpc_error_of([&] { store.resolve("sha256:" + std::string(64, '0')); }, rpc_code::not_found);

  ModelStore without(dir / "models", "");
  rpc_error_of([&] { without.resolve("file:blocks/a.stl"); }, rpc_code::invalid_params);
}

// A bad nominal was reported at "/model", the job's other model, whatever field held it.
TEST(ModelStore, EveryRefusalNamesTheFieldThatHeldTheReference) {
  const fs::path dir = fresh_folder("models-field");
  fs::create_directories(dir / "library");
  std::ofstream(dir / "secret.stl") << "outside\n";
  fs::create_symlink(dir / "secret.stl", dir / "library" / "escape.stl");
  ModelStore store(dir / "models", dir / "library"), without(dir / "models", "");
  Upload up;
  up.name = "part.stl";
  store.upload(up.chunk(0, up.bytes.size()));
  up.name = "part.ply";
  store.upload(up.chunk(0, 0));
  const std::string field = "/nominal/model";
  using Refs = std::vector<std::string>;
  // Malformed, in two formats without naming one, out of models_dir, no reference at all.
  for (const std::string& ref : Refs{"sha256:xyz", "sha256:" + up.sha + ".exe", "sha256:" + up.sha, "file:../secret.stl",
                                     "file:escape.stl", "file:", "model.stl"}) {
    const RpcError e = rpc_error_of([&] { store.resolve(ref, field); }, rpc_code::invalid_params);
    EXPECT_EQ(e.data().at("path"), field) << ref;
    EXPECT_THAT(e.what(), ::testing::StartsWith(field + ": ")) << ref;
  }
  EXPECT_EQ(rpc_error_of([&] { without.resolve("file:a.stl", field); }, rpc_code::invalid_params).data().at("path"), field);
  for (const std::string& ref : Refs{"sha256:" + std::string(64, '0'), "sha256:" + up.sha + ".obj", "file:missing.stl"}) {
    const RpcError e = rpc_error_of([&] { store.resolve(ref, field); }, rpc_code::not_found);
    EXPECT_EQ(e.data().at("path"), field) << ref;
    EXPECT_EQ(e.data().at("model"), ref);
  }
  // What job.submit's field check finds by the text alone, before any lookup.
  EXPECT_FALSE(model_ref_problem("sha256:" + up.sha + ".PLY"));
  EXPECT_FALSE(model_ref_problem("file:blocks/a.stl"));
  for (const std::string& ref : Refs{"sha256:0123", "sha256:" + up.sha + ".exe", "file:/etc/a.stl", "file:a/../../b.stl", "a.stl"})
    EXPECT_TRUE(model_ref_problem(ref)) << ref;
}

}  // namespace
}  // namespace cmm::daemon
