fn main() {
    println!("frameid: under construction");
}
